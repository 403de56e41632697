#include "dh/gov/decide.hpp"

namespace dh::gov {

void VerdictLatch::record(std::uint32_t step, bool value) {
  if (value && !pending_ && !latched_) {
    pending_ = true;
    pending_step_ = step;
  }
}

bool VerdictLatch::decide(std::uint32_t step) {
  if (pending_ && pending_step_ <= step && !latched_) {
    latched_ = true;
    event_step_ = pending_step_;
  }
  return latched_;
}

const char* to_string(CommandPhase p) {
  switch (p) {
    case CommandPhase::None: return "none";
    case CommandPhase::Running: return "running";
    case CommandPhase::Completed: return "completed";
    case CommandPhase::Failed: return "failed";
    case CommandPhase::Lost: return "lost";
    case CommandPhase::Refused: return "refused";
    case CommandPhase::Expired: return "expired";
  }
  return "?";
}

const char* to_string(DecisionKind k) {
  switch (k) {
    case DecisionKind::Continue: return "continue";
    case DecisionKind::StopSuccess: return "stop_success";
    case DecisionKind::Retry: return "retry";
    case DecisionKind::Substitute: return "substitute";
    case DecisionKind::InsertRecovery: return "insert_recovery";
    case DecisionKind::HandToVla: return "hand_to_vla";
    case DecisionKind::RequestReplan: return "request_replan";
    case DecisionKind::GiveUp: return "give_up";
  }
  return "?";
}

Decision decide(const DecisionState& s, const DecisionLimits& limits) {
  if (s.latched) return {DecisionKind::StopSuccess, "task verdict latched"};
  if (s.step >= s.budget_steps) return {DecisionKind::GiveUp, "episode budget exhausted"};
  const bool full = s.mode == ExecutorMode::Full;
  const bool can_replan = s.mode != ExecutorMode::Seq && s.replans_used < limits.max_replans;
  switch (s.phase) {
    case CommandPhase::Running:
      if (s.stagnant_decisions < limits.stagnation_decisions) return {DecisionKind::Continue, "command running"};
      if (full && s.recovery_available) return {DecisionKind::InsertRecovery, "no progress: insert recovery"};
      if (can_replan) return {DecisionKind::RequestReplan, "no progress for " + std::to_string(s.stagnant_decisions) + " decisions"};
      return {DecisionKind::GiveUp, "no progress and no replan left"};
    case CommandPhase::Completed:
      if (can_replan) return {DecisionKind::RequestReplan, "command completed but the task verdict is false"};
      return {DecisionKind::GiveUp, "command completed, verdict false, no replan left"};
    case CommandPhase::Lost:
      if (s.other_instance_alive) return {DecisionKind::Retry, "instance lost; re-ground on the newest live instance"};
      [[fallthrough]];
    case CommandPhase::Failed:
    case CommandPhase::Refused:
    case CommandPhase::Expired: {
      const std::string what = std::string("command ") + to_string(s.phase);
      if (s.phase != CommandPhase::Lost && s.failures_of_capability <= limits.max_retries)
        return {DecisionKind::Retry, what + "; retry " + std::to_string(s.failures_of_capability) + " of " +
                                         std::to_string(limits.max_retries)};
      if (full && s.substitute_available) return {DecisionKind::Substitute, what + "; substitute a capability"};
      if (full && s.recovery_available) return {DecisionKind::InsertRecovery, what + "; insert recovery"};
      if (full && s.vla_available) return {DecisionKind::HandToVla, what + "; hand the segment to vla_act"};
      if (can_replan) return {DecisionKind::RequestReplan, what + "; ask the planner"};
      return {DecisionKind::GiveUp, what + "; no eligible route left"};
    }
    case CommandPhase::None:
      if (can_replan) return {DecisionKind::RequestReplan, "no command grounded"};
      return {DecisionKind::GiveUp, "no command could be grounded"};
  }
  return {DecisionKind::GiveUp, "unreachable"};
}

}  // namespace dh::gov
