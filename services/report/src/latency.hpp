// What one episode's evidence file says beyond its outcome: decision and planner latencies, and the
// execution mechanisms the fast brain used (decisions by kind, refusals, commands per capability), and
// how the episode ended (its trace).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace dh::report {

struct Latencies {
  std::vector<double> decision_ms;  ///< "decision" records' latency_ns
  std::vector<double> planner_ms;   ///< "plan_request" → the later "advice" with the same request_id
  unsigned unanswered = 0;          ///< plan requests no advice answered
  void merge(const Latencies& other);
};

struct Mechanisms {
  unsigned episodes = 0;                    ///< episodes whose evidence was read
  std::map<std::string, unsigned> decisions;///< decision kind -> count ("request_replan" only after a
                                            ///< failure or stagnation; "next_step" after a completion)
  unsigned refusals = 0;                    ///< refusals at grounding or by a capability before motion
  std::map<std::string, std::pair<unsigned, unsigned>> commands;  ///< capability -> (dispatched, completed)
  /// capability -> control steps under its commands: from a dispatch to the next dispatch or the end.
  std::map<std::string, unsigned long> steps;
  /// The seam's 50 Hz envelope holding the arm (a joint over its speed limit): events, and episodes with any.
  unsigned long safety_holds = 0;
  unsigned episodes_held = 0;
  /// Control steps in which the arm controller's speed limiter braked a joint (docs/controller.md).
  unsigned long speed_limited = 0;
  void merge(const Mechanisms& other);
};

/// One episode as its evidence ends it, for the execution figures.
struct EpisodeTrace {
  long end_step = -1;            ///< the episode_end record's step; -1 when there is none
  long last_progress_step = 0;   ///< the last step a command's progress rose, or a command completed
  unsigned long policy_steps = 0;  ///< control steps under vla_act
  /// The verdict the episode ended on (its episode_start record; "oracle" in evidence from before the
  /// verifier was recorded); empty when the evidence was not read.
  std::string verifier;
  /// The arm on the scene's mount (its episode_request record): "" for the scene's own, the Panda.
  std::string robot;
  std::vector<std::string> predicates;  ///< the goal's predicate names (On, In, Open, ...), as recorded
  /// The goal judged on perceived frames latched true at some step; unset: no perceived verdict was kept
  /// (an arm that grounds from the robot's state, or evidence from before the verdict from perception).
  std::optional<bool> perceived;
  /// From the perceived_verdict_end record, to put a disagreement down to its cause: the oracle at the
  /// end; whether every goal term holds on the simulator's own poses under the perceived verdict's bands
  /// (unset when the record does not say: older evidence, a cell, no view at the end); no view at the end.
  std::optional<bool> oracle_at_end, terms_hold_on_true_poses;
  bool unperceived_at_end = false;
};

enum class EvidenceStatus { Read, Missing, NotRecorded };

/// Adds what the evidence file at `path` records to `latencies` and `mechanisms`, and fills `trace`. "" is
/// NotRecorded; a file that cannot be read is Missing and adds nothing; records with absent or mistyped
/// fields are skipped.
EvidenceStatus collect_evidence(const std::string& path, Latencies& latencies, Mechanisms& mechanisms,
                                EpisodeTrace& trace);

}  // namespace dh::report
