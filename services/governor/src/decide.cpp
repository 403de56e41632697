#include "dh/gov/decide.hpp"

namespace dh::gov {

void VerdictLatch::record(std::uint32_t step, bool value) {
  if (value && !pending_ && !latched_) {
    pending_ = true;
    pending_step_ = step;
  }
}

nlohmann::json VerdictLatch::state() const {
  return {{"latched", latched_}, {"pending", pending_}, {"pending_step", pending_step_}, {"event_step", event_step_}};
}

VerdictLatch VerdictLatch::from_state(const nlohmann::json& j) {
  VerdictLatch l;
  l.latched_ = j.at("latched").get<bool>();
  l.pending_ = j.at("pending").get<bool>();
  l.pending_step_ = j.at("pending_step").get<std::uint32_t>();
  l.event_step_ = j.at("event_step").get<std::uint32_t>();
  return l;
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
    case DecisionKind::Resume: return "resume";
    case DecisionKind::Substitute: return "substitute";
    case DecisionKind::InsertRecovery: return "insert_recovery";
    case DecisionKind::HandToVla: return "hand_to_vla";
    case DecisionKind::RequestReplan: return "request_replan";
    case DecisionKind::NextInSequence: return "next_in_sequence";
    case DecisionKind::GiveUp: return "give_up";
  }
  return "?";
}

namespace {

// What a fixed executor does once its retries are spent: static asks the planner to re-execute the plan
// from here, seq moves on through its frozen plan.
Decision fixed_fallback(const DecisionState& s, const DecisionLimits& limits, const std::string& what) {
  if (s.mode == ExecutorMode::Seq) {
    if (s.sequence_left) return {DecisionKind::NextInSequence, what + "; retries spent, next step of the frozen plan"};
    return {DecisionKind::GiveUp, what + "; retries spent and the frozen plan is exhausted"};
  }
  if (s.replans_used < limits.max_replans) return {DecisionKind::RequestReplan, what + "; re-execute the plan"};
  return {DecisionKind::GiveUp, what + "; no replan left"};
}

// The bare policy owns the episode: it runs until the verdict latches or the budget ends; a command that
// ended early (the policy failed, its instance was replaced) is handed the rest again, within the retries.
Decision decide_bare(const DecisionState& s, const DecisionLimits& limits) {
  switch (s.phase) {
    case CommandPhase::Running: return {DecisionKind::Continue, "bare policy running"};
    case CommandPhase::Refused: return {DecisionKind::GiveUp, "the policy refused the episode; nothing else may act"};
    case CommandPhase::Lost:
      if (!s.other_instance_alive) return {DecisionKind::GiveUp, "the policy's instance is lost and no other is alive"};
      return {DecisionKind::Retry, "policy instance lost; hand the rest to the newest live instance"};
    case CommandPhase::Completed:
    case CommandPhase::Failed:
    case CommandPhase::Expired:
      if (s.failures_of_step > limits.max_retries)
        return {DecisionKind::GiveUp, std::string("policy command ") + to_string(s.phase) + " again; retries spent"};
      return {DecisionKind::Retry, std::string("policy command ") + to_string(s.phase) + "; hand it the rest of the episode"};
    case CommandPhase::None: break;
  }
  return {DecisionKind::GiveUp, "no command and nothing to decide"};
}

Decision after_failure(const DecisionState& s, const DecisionLimits& limits) {
  const std::string what = std::string("command ") + to_string(s.phase);
  const bool retry_left = s.failures_of_step <= limits.max_retries;
  const std::string retry = "retry " + std::to_string(s.failures_of_step) + " of " + std::to_string(limits.max_retries);
  if (s.phase == CommandPhase::Lost && s.other_instance_alive)
    return {DecisionKind::Retry, "instance lost; re-ground on the newest live instance"};
  if (s.mode != ExecutorMode::Full) {
    // Fixed executors repeat what failed, refusals included.
    if (retry_left) return {DecisionKind::Retry, what + "; " + retry};
    return fixed_fallback(s, limits, what);
  }
  // A refusal happens before any motion, and a lost capability has no instance left: repeating the same
  // command cannot help.
  const bool repeatable = s.phase != CommandPhase::Refused && s.phase != CommandPhase::Lost;
  if (repeatable && retry_left) {
    if (s.recovery_available && s.recoveries_left && !s.was_recovery)
      return {DecisionKind::InsertRecovery, what + "; insert a recovery, then " + retry};
    return {DecisionKind::Retry, what + "; " + retry};
  }
  if (s.substitute_available) return {DecisionKind::Substitute, what + "; substitute an eligible capability for the same goal"};
  // A step no eligible capability will take goes back to the slow brain first (the paper, Appendix A): the
  // planner may have named the wrong object or capability, and a new plan costs no control step, where
  // vla_act spends its whole budget on a step the library already judged infeasible. The step comes back
  // to vla_act only when the planner advises it again.
  if (s.phase == CommandPhase::Refused && s.failures_of_step <= 1 && s.replans_used < limits.max_replans)
    return {DecisionKind::RequestReplan, what + "; no eligible capability takes the step: return it to the planner"};
  if (s.vla_available) return {DecisionKind::HandToVla, what + "; no analytic route left: hand the segment to vla_act"};
  if (s.replans_used < limits.max_replans) return {DecisionKind::RequestReplan, what + "; ask the planner"};
  return {DecisionKind::GiveUp, what + "; no retry, substitute, policy or replan left"};
}

}  // namespace

Decision decide(const DecisionState& s, const DecisionLimits& limits) {
  if (s.latch_enabled && s.latched) return {DecisionKind::StopSuccess, "task verdict latched"};
  if (s.step >= s.budget_steps) return {DecisionKind::GiveUp, "episode budget exhausted"};
  if (s.mode == ExecutorMode::Bare) return decide_bare(s, limits);
  switch (s.phase) {
    case CommandPhase::Running:
      if (s.stagnant_decisions < limits.stagnation_decisions) return {DecisionKind::Continue, "command running"};
      if (s.mode == ExecutorMode::Full && s.recovery_available && s.recoveries_left && !s.was_recovery)
        return {DecisionKind::InsertRecovery, "no progress for " + std::to_string(s.stagnant_decisions) +
                                                  " decisions: insert a recovery"};
      if (s.mode == ExecutorMode::Seq)
        return fixed_fallback(s, limits, "no progress for " + std::to_string(s.stagnant_decisions) + " decisions");
      if (s.replans_used < limits.max_replans)
        return {DecisionKind::RequestReplan, "no progress for " + std::to_string(s.stagnant_decisions) + " decisions"};
      return {DecisionKind::GiveUp, "no progress and no replan left"};
    case CommandPhase::Completed:
      if (s.was_recovery) return {DecisionKind::Resume, "recovery completed; resume the interrupted step"};
      if (s.mode == ExecutorMode::Seq) {
        if (s.sequence_left) return {DecisionKind::NextInSequence, "command completed; next step of the frozen plan"};
        return {DecisionKind::GiveUp, "the frozen plan is exhausted and the task verdict is false"};
      }
      // Nominal one-step replanning: the slow brain names the next step (not counted against max_replans).
      return {DecisionKind::RequestReplan, "command completed; ask for the next step"};
    case CommandPhase::Failed:
    case CommandPhase::Expired:
    case CommandPhase::Lost:
    case CommandPhase::Refused:
      if (s.was_recovery) return {DecisionKind::Resume, std::string("recovery ") + to_string(s.phase) + "; resume the interrupted step"};
      return after_failure(s, limits);
    case CommandPhase::None:
      break;
  }
  return {DecisionKind::GiveUp, "no command and nothing to decide"};
}

nlohmann::json to_json(const DecisionState& s) {
  return {{"mode", static_cast<int>(s.mode)}, {"latch_enabled", s.latch_enabled}, {"latched", s.latched},
          {"phase", static_cast<int>(s.phase)}, {"step", s.step}, {"budget_steps", s.budget_steps},
          {"progress", s.progress}, {"stagnant", s.stagnant_decisions}, {"failures", s.failures_of_step},
          {"replans", s.replans_used}, {"was_recovery", s.was_recovery}, {"recoveries_left", s.recoveries_left},
          {"other_instance", s.other_instance_alive}, {"substitute", s.substitute_available},
          {"recovery", s.recovery_available}, {"vla", s.vla_available}, {"sequence_left", s.sequence_left}};
}

DecisionState state_from_json(const nlohmann::json& j) {
  DecisionState s;
  s.mode = static_cast<ExecutorMode>(j.at("mode").get<int>());
  s.latch_enabled = j.at("latch_enabled");
  s.latched = j.at("latched");
  s.phase = static_cast<CommandPhase>(j.at("phase").get<int>());
  s.step = j.at("step");
  s.budget_steps = j.at("budget_steps");
  s.progress = j.at("progress");
  s.stagnant_decisions = j.at("stagnant");
  s.failures_of_step = j.at("failures");
  s.replans_used = j.at("replans");
  s.was_recovery = j.at("was_recovery");
  s.recoveries_left = j.at("recoveries_left");
  s.other_instance_alive = j.at("other_instance");
  s.substitute_available = j.at("substitute");
  s.recovery_available = j.at("recovery");
  s.vla_available = j.at("vla");
  s.sequence_left = j.at("sequence_left");
  return s;
}

}  // namespace dh::gov
