#include "dh/common/lifecycle.hpp"

#include <exception>

namespace dh {

const char* to_string(LifecycleState s) {
  switch (s) {
    case LifecycleState::Unconfigured: return "unconfigured";
    case LifecycleState::Inactive: return "inactive";
    case LifecycleState::Active: return "active";
    case LifecycleState::Draining: return "draining";
    case LifecycleState::Finalized: return "finalized";
  }
  return "?";
}

const char* to_string(LifecycleTransition t) {
  switch (t) {
    case LifecycleTransition::Configure: return "configure";
    case LifecycleTransition::Activate: return "activate";
    case LifecycleTransition::Drain: return "drain";
    case LifecycleTransition::Deactivate: return "deactivate";
    case LifecycleTransition::Shutdown: return "shutdown";
  }
  return "?";
}

TransitionResult Lifecycle::trigger(LifecycleTransition t) {
  using S = LifecycleState;
  using T = LifecycleTransition;
  S to{};
  const std::function<void()>* callback = nullptr;
  bool allowed = false;
  switch (t) {
    case T::Configure:
      allowed = state_ == S::Unconfigured, to = S::Inactive, callback = &callbacks_.configure;
      break;
    case T::Activate:
      allowed = state_ == S::Inactive, to = S::Active, callback = &callbacks_.activate;
      break;
    case T::Drain:
      allowed = state_ == S::Active, to = S::Draining, callback = &callbacks_.drain;
      break;
    case T::Deactivate:
      allowed = state_ == S::Active || state_ == S::Draining, to = S::Inactive, callback = &callbacks_.deactivate;
      break;
    case T::Shutdown:
      allowed = state_ != S::Finalized, to = S::Finalized, callback = &callbacks_.shutdown;
      break;
  }
  TransitionResult r{t, state_, state_, false, {}};
  if (!allowed) {
    r.reason = std::string("cannot ") + to_string(t) + " from " + to_string(state_);
    return r;
  }
  try {
    if (*callback) (*callback)();
  } catch (const std::exception& e) {
    r.reason = e.what();
    return r;
  } catch (...) {
    r.reason = "an exception that is not a std::exception";
    return r;
  }
  state_ = to;
  r.to = to;
  r.ok = true;
  return r;
}

}  // namespace dh
