// One finished episode of a campaign: the row a campaign database holds and a report reads.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace dh {

struct EpisodeRecord {
  // The paired key: two arms are compared on the same (cell, task, seed).
  std::string arm;   ///< executor configuration, e.g. "full", "static", "seq"
  std::string cell;  ///< "goal", "goal-task", "goal-swap", "long", "long-task", "long-swap"
  unsigned task = 0;
  unsigned seed = 0;

  bool success = false;
  unsigned steps = 0;       ///< control steps applied
  unsigned budget = 0;      ///< the task's step budget
  double wall_s = 0;        ///< request sent → result received (s)
  double physics_s = 0;     ///< time the simulator spent in MuJoCo for this episode (s); 0 = unknown
  std::string outcome;      ///< "success", "budget_exhausted", "gave_up", "infrastructure"
  std::string reason;
  bool infrastructure = false;  ///< lost to infrastructure (no result, dead process); counted as a failure
  bool tick_limit = false;      ///< ended because the step budget ran out
  std::string evidence_path;    ///< the episode's JSON-lines evidence file ("" when none was written)
  std::string episode_id;
  std::string worker;           ///< sim_worker name that ran it
  unsigned channel = 0;
  std::string finished_at;      ///< UTC ISO-8601

  // The simulator's own verdict, reported by the channel that ran the episode, beside the governor's
  // `success`. LIBERO's rule: the goal held at some step. Unknown when no report came (a lost episode).
  std::optional<bool> sim_success;
  int sim_goal_step = -1;  ///< the first step the goal held (-1: never, or unknown)
  bool sim_goal_at_end = false;  ///< the goal held in the state the episode ended in
  /// Capabilities the arm needs that had no live instance when the episode started: it ran without them
  /// (a `full` without a trained `vla_act` is `no-vla` in effect). Unknown when no result came (a lost
  /// episode) or the row predates the record.
  std::optional<std::vector<std::string>> capabilities_missing;
  /// The simulator and the governor disagree on the episode's success.
  bool verdict_disagrees() const { return sim_success && *sim_success != success; }
  /// The cluster its interval is clustered by: "cell/task" (a task's seeds share a layout).
  std::string cluster() const { return cluster_of(cell, task); }
  static std::string cluster_of(const std::string& cell, unsigned task) { return cell + "/" + std::to_string(task); }
};

}  // namespace dh
