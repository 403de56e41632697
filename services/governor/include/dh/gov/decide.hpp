// The fast brain's decision: a deterministic function of the execution state (DESIGN.md §5). It is
// called at every decision step (every 10 control steps, 2 Hz of a 20 Hz controller) and whenever a
// command ends; each decision carries its reason and is recorded.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace dh::gov {

/// Verdict latch: v_k = v_{k-1} OR any verdict event since the previous decision (Eq. 3).
class VerdictLatch {
 public:
  void record(std::uint32_t step, bool value);  ///< an event from the checks (every step)
  /// Reads the events up to `step` into the latch and returns v_k. Once true, it stays true.
  bool decide(std::uint32_t step);
  bool latched() const { return latched_; }
  std::uint32_t event_step() const { return event_step_; }  ///< first step the predicate held
  /// Its whole state, for the episode machine's snapshot: {latched, pending, pending_step, event_step}.
  nlohmann::json state() const;
  static VerdictLatch from_state(const nlohmann::json& j);

 private:
  bool latched_ = false;
  bool pending_ = false;
  std::uint32_t pending_step_ = 0, event_step_ = 0;
};

/// full: dynamic decisions; static: nominal one-step replanning after successes, fixed retries and plan
/// re-execution after failures; seq: one up-front plan run in order with fixed retries; bare: no planner
/// and no analytic route: vla_act is handed the whole episode (the bare-policy baseline).
enum class ExecutorMode { Full, Static, Seq, Bare };

/// How the command the decision is about stands. Refused: the capability (or grounding) refused before
/// any motion, so repeating it cannot help; Failed/Expired: it moved and did not complete.
enum class CommandPhase { None, Running, Completed, Failed, Lost, Refused, Expired };
const char* to_string(CommandPhase p);

struct DecisionState {
  ExecutorMode mode = ExecutorMode::Full;
  bool latch_enabled = true;
  bool latched = false;
  CommandPhase phase = CommandPhase::None;
  std::uint32_t step = 0, budget_steps = 0;
  double progress = 0;
  std::uint32_t stagnant_decisions = 0;  ///< decisions in a row without progress
  int failures_of_step = 0;              ///< failures of this capability on these arguments in this episode
  int replans_used = 0;
  bool was_recovery = false;             ///< the command was a recovery the fast brain inserted
  bool recoveries_left = false;          ///< the step may still get a recovery inserted
  bool other_instance_alive = false;     ///< the capability has another live instance (hot swap)
  bool substitute_available = false;     ///< another eligible capability serves the same arguments
  bool recovery_available = false;       ///< a recovery capability is eligible
  bool vla_available = false;
  bool sequence_left = false;            ///< seq: steps of the frozen plan remain
};

struct DecisionLimits {
  int max_retries = 1;            ///< re-grounds of the same step after a failure
  int max_replans = 4;            ///< slow-brain calls after failures or stagnation
  std::uint32_t stagnation_decisions = 8;
};

enum class DecisionKind {
  Continue, StopSuccess, Retry, Resume, Substitute, InsertRecovery, HandToVla, RequestReplan, NextInSequence, GiveUp
};
const char* to_string(DecisionKind k);

struct Decision {
  DecisionKind kind = DecisionKind::Continue;
  std::string reason;
};

Decision decide(const DecisionState& s, const DecisionLimits& limits);

/// The state as recorded in a decision's evidence ("state"), and back: recorded decisions can be replayed
/// (bench_decide does). from_json throws nlohmann::json::exception on a record without the fields.
nlohmann::json to_json(const DecisionState& s);
DecisionState state_from_json(const nlohmann::json& j);

}  // namespace dh::gov
