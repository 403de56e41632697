// The life of a service process: SIGINT/SIGTERM handlers installed, the body run until it returns
// (nodes loop while !shutdown_requested()), an exception logged with its message as exit code 1.
#pragma once

#include <spdlog/logger.h>

#include <functional>

#include "dh/common/shutdown.hpp"

namespace dh {

int run_service(spdlog::logger& log, const std::function<void()>& body);

}  // namespace dh
