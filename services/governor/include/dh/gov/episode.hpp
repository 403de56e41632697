// One channel's episode under the fast brain: plan -> ground (or refuse) -> dispatch -> monitor and
// decide every `decision_period` steps -> end on the latched verdict, budget exhaustion or giving up.
// Pure logic: inputs are plain messages and a monotonic time; outputs are Effects the node publishes.
// Every observation summary, decision, refusal, dispatch, outcome and reason goes to the evidence store.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dh/common/evidence.hpp"
#include "dh/common/goal.hpp"
#include "dh/common/observation.hpp"
#include "dh/common/perceived_world.hpp"
#include "dh/common/planner_errors.hpp"
#include "dh/common/robot_contract.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/gov/decide.hpp"
#include "dh/gov/grounding.hpp"
#include "dh/gov/perceived_verdict.hpp"
#include "dh/gov/registry.hpp"
#include "dh/gov/types.hpp"

namespace dh::gov {

using Clock = std::chrono::steady_clock;

struct GovernorConfig {
  std::uint32_t decision_period = robot::kDecisionPeriodSteps;  ///< control steps between decisions
  ExecutorMode mode = ExecutorMode::Full;
  DecisionLimits limits;
  int max_refusals = 4;                ///< refusals in a row before the episode is given up
  int max_recoveries = 1;              ///< recoveries inserted per step
  bool latch = true;                   ///< end on the latched verdict (off: the final state decides)
  std::set<std::string> masked;        ///< capabilities switched off (ablations)
  /// Capabilities that serve the same arguments' goal another way (push -> pick_place).
  std::map<std::string, std::vector<std::string>> substitutes;
  std::chrono::milliseconds planner_timeout{10000};
  std::chrono::milliseconds ack_timeout{3000};
  std::chrono::milliseconds first_observation_timeout{15000};
  std::chrono::milliseconds step_stall_timeout{10000};  ///< no observation while a command runs
  /// Set: ground from the perception service's scene estimates (arm `grounding: perception`).
  std::optional<PerceptionLimits> perception;
  PerceptionLimits perception_limits;  ///< the `perception:` section, used by arms that ground from it
  /// The verdict the episode latches and ends on; Perception needs perception grounding and a goal.
  Verifier verifier = Verifier::Oracle;
  /// Perceived frames in a row that must agree before the perceived verdict changes (`verdict_frames`).
  std::uint32_t verdict_frames = 3;
  /// With verifier perception, how many frames of the final state (of the step the plan completed at, or
  /// later) a plan's completion waits for the perceived verdict, which lags the world by its frames
  /// (`verdict_wait_frames`): counted in frames, so a loaded machine's slow frames do not decide it.
  std::uint32_t verdict_wait_frames = 12;
  /// ... and the longest it waits for them; past it the perception service is lost (`verdict_wait_ms`).
  std::chrono::milliseconds verdict_wait{30000};
};

struct EpisodeSpec {
  std::uint32_t channel = 0;
  std::string episode_id, instruction, arm;
  std::uint32_t budget_steps = 0;
  /// The capability library the episode runs (idl EpisodeRequest): its version and θ by capability;
  /// empty runs every capability with the θ its instance announced.
  std::string library_version{};
  std::map<std::string, std::map<std::string, double>> library{};
  /// The cost model under that θ, by capability (steps); a capability without one: its announced cost.
  std::map<std::string, std::uint32_t> library_costs{};
  /// The request's settings for this episode; unset: the governor's configuration and the arm's.
  std::optional<std::uint32_t> decision_period{};
  std::optional<std::string> grounding{};        ///< "state" | "perception"
  std::optional<PerceptionLimits> perception{};  ///< the limits with "perception"
  std::uint64_t error_seed = 0;                  ///< with planner_errors: their draws' (planner_error_seed)
  PlannerErrorRates planner_errors{};
  /// The task's goal, resolved against the cell's description: what the perceived verdict evaluates.
  std::vector<GoalTerm> goal{};
  /// The request's verifier; none: a code this governor does not know (the episode is refused).
  std::optional<Verifier> verifier = Verifier::Oracle;
};

struct PlanRequestOut {
  std::string request_id, instruction;
  std::vector<EntityState> scene;
  std::vector<std::string> capabilities, history;
  std::uint32_t step = 0;
  std::uint64_t seed = 0;    ///< the error draws' (EpisodeSpec::error_seed)
  std::uint32_t index = 0;   ///< the request's number in the episode, from 0
  PlannerErrorRates errors;  ///< the episode's planner-error rates
};

struct EpisodeEnd {
  bool success = false;
  std::uint32_t steps = 0;
  Outcome outcome = Outcome::GaveUp;
  std::string reason;
  std::uint32_t decisions = 0, refusals = 0;
  /// Capabilities the arm needs that had no live instance at the start: the episode ran without them.
  std::vector<std::string> capabilities_missing;
};

struct Effects {
  std::optional<PlanRequestOut> plan_request;
  std::optional<Command> command;
  std::optional<Lease> lease;
  std::optional<std::string> cancel_command;
  std::optional<EpisodeEnd> end;
};

/// An episode's first evidence record, what was asked for, written by whoever takes the request (the
/// governor's shell, the in-process stack) before the machine exists, and read by `dh replay`.
void record_request(EvidenceWriter& evidence, const std::string& suite, std::uint32_t task, std::uint64_t seed,
                    const std::string& cell, const std::string& arm, const std::string& robot = "",
                    const PlannerErrorRates& planner_errors = {});

/// What a decision was made on, recorded once it is made (so its latency holds no recording): the decision
/// step's observation; the end of the running command, added to the history and, when `ended_unrecorded`,
/// its status recorded.
struct DecidedOn {
  const Observation* observed = nullptr;
  const CommandStatus* ended = nullptr;
  bool ended_unrecorded = false;
};

/// A machine's state at one instant (episode.hpp's snapshot), for the evidence and for resuming an episode
/// from a command's start (the probe's rest of an episode). `state` is everything but the waits: the
/// episode's spec, its phase, the last observation, the latch, the step being executed and the plan's rest,
/// what was tried and failed, the running command, the history and the counters. `waits` holds each
/// pending wait's time left from the snapshot's instant (ns) and what the current one waits for (its text
/// names the process it waits on): over DDS that is what the clock and the deployment gave, so comparisons
/// leave it aside as they do wall-clock stamps. The channel an episode ran on is where it ran, not its
/// state: a snapshot leaves it out.
struct MachineSnapshot {
  nlohmann::json state, waits;
};

/// The episode's spec in a snapshot (channel 0). Throws std::invalid_argument for one that cannot be read.
EpisodeSpec snapshot_spec(const MachineSnapshot& s);

class EpisodeMachine {
 public:
  EpisodeMachine(EpisodeSpec spec, const GovernorConfig& config, const Registry& registry,
                 EvidenceWriter& evidence, Clock::time_point now);

  Effects on_observation(Observation obs, Clock::time_point now);
  Effects on_advice(const Advice& advice, Clock::time_point now);
  Effects on_status(const CommandStatus& status, Clock::time_point now);
  Effects on_capability_lost(const std::string& instance, Clock::time_point now);
  void on_verdict(std::uint32_t step, const std::string& predicate, bool value);
  /// The perception service's latest estimates for this episode (kept only under perception grounding);
  /// a step waiting for a fresh estimate is grounded with it.
  Effects on_scene_estimate(const SceneEstimate& estimate, Clock::time_point now);
  /// The seam's refusals and corrections go to the evidence; an Ended event (the cell failed, or the seam
  /// gave the episode up) ends it as infrastructure with the seam's reason, without waiting for a deadline.
  Effects on_seam_event(const SeamEvent& e);
  /// When the wait in progress (planner, acknowledgement, next observation, ...) runs out: on_tick at or
  /// after it acts. The in-process bus advances its clock to it when nothing else can happen.
  Clock::time_point deadline() const { return deadline_; }
  /// Ends waits whose computed deadline passed (planner, acknowledgement, stalled steps).
  Effects on_tick(Clock::time_point now);

  /// The machine's state at `now`; under perception grounding with it the perceived world and the
  /// perceived verdict's frames.
  MachineSnapshot snapshot(Clock::time_point now) const;
  /// A machine on `channel` in the state `s` was taken in, its waits counted from `now`, writing from now
  /// on to `evidence` (it records nothing itself). `config` is the episode's configuration (the arm's and
  /// the request's, as the governor made it; its grounding must be the snapshot's). Throws
  /// std::invalid_argument naming what is missing or not restorable.
  static std::unique_ptr<EpisodeMachine> restore(const MachineSnapshot& s, std::uint32_t channel,
                                                 const GovernorConfig& config, const Registry& registry,
                                                 EvidenceWriter& evidence, Clock::time_point now);
  /// The episode goes on under `library` (a candidate's: the probe's rest of an episode): the command in
  /// flight runs under its θ there and `budget_steps`, and its lease and command are returned to be
  /// dispatched again; later commands are grounded with the library's θ. Throws std::logic_error when no
  /// command runs.
  Effects redispatch(const std::string& library_version,
                     const std::map<std::string, std::map<std::string, double>>& library,
                     const std::map<std::string, std::uint32_t>& library_costs, std::uint32_t budget_steps,
                     Clock::time_point now);

  bool ended() const { return phase_ == Phase::Ended; }
  const EpisodeSpec& spec() const { return spec_; }
  std::uint32_t decisions() const { return decisions_; }

 private:
  /// For restore: a machine that records nothing at its construction.
  EpisodeMachine(EpisodeSpec spec, const GovernorConfig& config, const Registry& registry, EvidenceWriter& evidence);
  /// AwaitingCapability: the bare arm's policy has not been announced to this governor yet.
  /// AwaitingPerception: planning or grounding from perception waits for a fresh scene estimate.
  /// Verifying: the plan is complete and the perceived verdict, which lags by its frames, is awaited.
  enum class Phase { WaitingFirstObservation, Planning, AwaitingCapability, AwaitingPerception, Running, Ended, Verifying };
  Effects request_plan(const std::string& why, Clock::time_point now);
  /// Under perception grounding, when the latest scene estimate is missing or stale and the wait for one
  /// (config perception.wait, from the first time it was missing) is not over: waits for it, to ground
  /// `advice` or, without one, to plan; true then.
  bool wait_for_perception(const std::optional<Advice>& advice, Clock::time_point now);
  Observation perceived_scene();  ///< the last observation as the planner may see it
  Effects ground_and_dispatch(const Advice& advice, Clock::time_point now);
  Effects refuse(Refusal r, const std::string& reason, Clock::time_point now);
  Effects decide_now(CommandPhase phase, const std::string& cause, Clock::time_point now, DecidedOn on = {});
  /// The grounding and dispatch records of a command sent at the current step.
  void record_dispatch(const Command& c);
  /// Records a failure of the current step's command (by capability and arguments).
  void count_failure();
  /// The step being executed becomes `advice`; its signature and key are made here, once, not per decision.
  void set_step(Advice advice);
  /// While a command runs: the next observation is due within the step-stall timeout.
  void await_observation(Clock::time_point now);
  bool eligible(const std::string& capability) const;
  std::optional<std::string> substitute() const;  ///< an eligible capability not yet tried for this step
  /// reseat after a one-finger contact, regrasp after a missed or lost grasp, release_retreat with
  /// something in hand, else keyframe_return
  std::string recovery_for() const;
  std::string recovery_object() const;            ///< the interrupted step's object argument, or ""
  FailureCode last_failure_ = FailureCode::None;  ///< why the last command that did not complete failed
  Effects end(bool success, Outcome outcome, const std::string& reason);
  Effects stop_command();  ///< cancel + revoking lease for the running command, if any
  /// `next` after `first` (a stop, a step's decision): what `next` does not set itself, `first`'s rides along.
  static Effects then(const Effects& first, Effects next);
  /// Decides on the running command's end; `unrecorded`: its status is recorded after the decision.
  Effects finish_command(const CommandStatus& st, Clock::time_point now, bool unrecorded);
  /// The lease with the running command's budget raised to its capability's plan (raised_budget), if it is.
  Effects raise_budget(const CommandStatus& st);
  void record_status(const CommandStatus& st);
  /// Folds the progress reports of steps before `step` (through it, with `through`) into last_progress_.
  void take_progress(std::uint32_t step, bool through);
  nlohmann::json obs_summary(const Observation& o) const;
  /// The perceived verdict at the end, each goal term judged as perceived and on the simulator's poses.
  nlohmann::json perceived_verdict_end(std::uint32_t step);

  EpisodeSpec spec_;
  GovernorConfig config_;
  const Registry& registry_;
  EvidenceWriter& evidence_;
  Phase phase_ = Phase::WaitingFirstObservation;
  Clock::time_point deadline_;
  std::chrono::steady_clock::time_point arrived_;  ///< when the event being handled reached the core
  Clock::time_point capability_wait_until_;  ///< the bare arm waits this long for vla_act's announcement
  std::string deadline_what_;
  /// What a missed wait was for, as a code its deadline_missed record carries beside the text (attribution
  /// reads it): first_observation, observation, planner, acknowledgement. (Waits for an announcement or a
  /// scene estimate end in a refusal, which is recorded instead.)
  std::string deadline_wait_;

  Observation last_obs_;
  bool have_obs_ = false;
  std::optional<PerceivedWorld> world_;  ///< set under perception grounding
  /// Under perception grounding with a goal: the goal judged on perceived frames (recorded whatever the
  /// verifier; latched and ended on when the verifier is perception).
  std::optional<PerceivedVerdict> perceived_;
  std::uint32_t verifying_from_ = 0;  ///< Verifying: the step the plan completed at
  std::uint32_t final_frames_ = 0;    ///< Verifying: frames of the final state judged since
  /// The verdict the episode goes by now: the oracle's at the last observation, or the perceived one.
  bool verdict_now() const;
  /// The step waiting for a fresh scene estimate to be grounded; none while a plan request waits for one.
  std::optional<Advice> awaiting_perception_;
  Clock::time_point perception_wait_until_;
  VerdictLatch latch_;
  std::optional<Advice> last_advice_;            ///< the step being executed (capability + arguments); set_step
  std::string step_signature_;                   ///< history::signature of its arguments
  std::string step_key_;                         ///< its capability and signature: failures_'s key
  std::optional<Advice> resume_;                 ///< the step a recovery interrupted
  std::vector<PlanStep> sequence_;               ///< seq: the frozen plan's remaining steps
  std::map<std::string, std::set<std::string>> tried_;  ///< per argument signature: capabilities tried
  std::map<std::string, int> recoveries_;         ///< per argument signature: recoveries inserted
  bool recovering_ = false;                       ///< the command in flight is an inserted recovery
  std::optional<Command> running_;
  std::optional<CommandStatus> deferred_end_;  ///< a command end reported before its observation arrived
  bool acknowledged_ = false;
  double last_progress_ = 0, progress_at_decision_ = 0;
  /// Progress reports (step, progress) not yet taken: a decision at step t takes those of steps before t,
  /// whichever topic DDS delivered first, so it sees what it would in process (reports of step t come
  /// after the observation of step t there).
  std::vector<std::pair<std::uint32_t, double>> progress_reports_;
  std::uint32_t stagnant_ = 0;
  std::map<std::string, int> failures_;  ///< per capability and arguments
  std::vector<std::string> history_;
  std::string pending_request_;
  std::uint32_t decisions_ = 0, refusals_total_ = 0;
  std::vector<std::string> capabilities_missing_;
  int refusals_in_row_ = 0, replans_ = 0, plans_ = 0, commands_ = 0;
};

}  // namespace dh::gov
