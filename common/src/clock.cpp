#include "dh/common/clock.hpp"

#include <unistd.h>

#include <ctime>

namespace dh {

std::string utc_time(const char* format) {
  char stamp[64];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::strftime(stamp, sizeof stamp, format, &tm);
  return stamp;
}

std::string run_tag() { return utc_time("%Y%m%dT%H%M%S") + "-" + std::to_string(getpid()); }

}  // namespace dh
