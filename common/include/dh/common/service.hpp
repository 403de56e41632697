// The life of a service process: SIGINT/SIGTERM handlers installed, then its managed lifecycle
// (lifecycle.hpp) driven from start to exit: configure, activate, the active loop until a stop is asked
// for, drain, deactivate, shut down. Each transition is logged with its result.
#pragma once

#include <spdlog/logger.h>

#include <chrono>
#include <functional>

#include "dh/common/lifecycle.hpp"
#include "dh/common/shutdown.hpp"

namespace dh {

struct ManagedService {
  LifecycleCallbacks transitions;
  /// One turn of the active loop (it waits for an event at most briefly). It runs while active and while
  /// draining; an exception from it ends the process with the message as the reason.
  std::function<void()> step;
  /// While draining: true once nothing is left to finish; unset: nothing to finish.
  std::function<bool()> drained;
  std::chrono::milliseconds drain_timeout{0};
};

/// Runs `service` through its lifecycle. Returns 0, or 1 when a transition or the loop failed (what was
/// configured is still deactivated and shut down).
int run_managed(spdlog::logger& log, ManagedService service);

}  // namespace dh
