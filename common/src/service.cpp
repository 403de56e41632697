#include "dh/common/service.hpp"

#include <exception>

namespace dh {

int run_service(spdlog::logger& log, const std::function<void()>& body) {
  install_shutdown_handlers();
  try {
    body();
  } catch (const std::exception& e) {
    log.error("{}", e.what());
    return 1;
  }
  log.info("shutting down");
  return 0;
}

}  // namespace dh
