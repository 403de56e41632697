// One spdlog logger per service; level from DH_LOG_LEVEL (trace, debug, info, warn, error).
#pragma once

#include <spdlog/spdlog.h>

#include <memory>
#include <string>

namespace dh {

std::shared_ptr<spdlog::logger> make_logger(const std::string& service);

}  // namespace dh
