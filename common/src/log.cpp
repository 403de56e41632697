#include "dh/common/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <cstdlib>

namespace dh {

std::shared_ptr<spdlog::logger> make_logger(const std::string& service) {
  if (auto existing = spdlog::get(service)) return existing;
  auto logger = spdlog::stderr_color_mt(service);
  logger->set_pattern("%H:%M:%S.%e %^%l%$ [%n] %v");
  const char* level = std::getenv("DH_LOG_LEVEL");
  logger->set_level(level ? spdlog::level::from_str(level) : spdlog::level::info);
  return logger;
}

}  // namespace dh
