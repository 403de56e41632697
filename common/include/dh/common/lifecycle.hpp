// A service process's managed lifecycle, with the semantics of ROS 2 managed nodes
// (design.ros2.org/articles/node_lifecycle.html), plus drain:
//
//   unconfigured --configure--> inactive --activate--> active --drain--> draining
//   active, draining --deactivate--> inactive;   any state --shutdown--> finalized
//
// configure reads the service's own configuration and makes its core, participant and writers; activate
// makes its readers (events start to flow) and starts asserting liveliness; drain takes no new work and
// lets what runs finish; deactivate removes the readers; shutdown deletes the rest. A transition runs the
// service's callback: when the callback throws, the transition fails with its message as the reason and
// the state stays where it was; a transition the state does not allow is refused, naming the state.
// DDS-free: run_managed (service.hpp) drives it for a process, tests drive it directly.
#pragma once

#include <functional>
#include <string>

namespace dh {

enum class LifecycleState { Unconfigured, Inactive, Active, Draining, Finalized };
enum class LifecycleTransition { Configure, Activate, Drain, Deactivate, Shutdown };

const char* to_string(LifecycleState s);
const char* to_string(LifecycleTransition t);

struct TransitionResult {
  LifecycleTransition transition{};
  LifecycleState from{}, to{};  ///< to == from when it failed
  bool ok = false;
  std::string reason;  ///< why it failed; empty when it succeeded
};

/// What a service does on each transition; an unset callback has nothing to do.
struct LifecycleCallbacks {
  std::function<void()> configure, activate, drain, deactivate, shutdown;
};

class Lifecycle {
 public:
  explicit Lifecycle(LifecycleCallbacks callbacks) : callbacks_(std::move(callbacks)) {}
  TransitionResult trigger(LifecycleTransition t);
  LifecycleState state() const { return state_; }

 private:
  LifecycleCallbacks callbacks_;
  LifecycleState state_ = LifecycleState::Unconfigured;
};

}  // namespace dh
