// An episode's recording as the replay and the probe read it: the governor's evidence (<episode>.jsonl)
// gives the task, the seed, and each command's grounding, dispatch and end; the seam's state log
// (<episode>.states) gives the physics state at each command's start. From them the capability host core's
// state at a command's start is re-made: the keyframes the earlier commands left.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/cap/host_core.hpp"
#include "dh/gov/episode.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {

/// A recording that is missing, corrupt, or lacks what a re-run needs; what() names the file (bad input).
struct EvidenceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Where a re-run first departs from its recording.
struct Divergence {
  std::uint32_t step = 0;
  std::string body;      ///< the joint's body, "world" for the solver state, or the capability for actions
  std::string quantity;  ///< e.g. "qpos:joint3", "qvel:bowl_joint", "qacc_warmstart", "action[2]"
};

/// Where the cell's state at `step` differs from the recorded digest `want`: the first joint and
/// quantity, else the solver state.
Divergence divergence_at(const sim::Workcell& cell, std::uint32_t step, const sim::StateDigest& want);
/// {step, body, quantity}, or null.
nlohmann::json to_json(const std::optional<Divergence>& d);

/// A command's end as the host reported it (the evidence's command_status record).
struct RecordedEnd {
  std::string state, failure, stage;  ///< to_string of CommandState and FailureCode
  std::uint32_t step = 0;             ///< the step the end was reported at
  std::uint32_t steps_used = 0;
};

/// A command as the evidence recorded it: its grounding (capability, arguments, θ) and its dispatch.
struct RecordedCommand {
  std::string id, capability, version;
  nlohmann::json args, theta;
  std::uint32_t start_step = 0, budget_steps = 0;
  /// The governor's raises of the budget for a plan longer than the cost model: (the step of the status
  /// that said the plan, the budget from then on), in order (its budget_raised records).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> budget_raises;
  std::optional<RecordedEnd> end;  ///< none when the governor moved on before the command ended
  /// The governor's episode machine just after the dispatch (its evidence's snapshot record); none in
  /// evidence written before snapshots were recorded.
  std::optional<gov::MachineSnapshot> snapshot;
};

/// The episode's end as the governor recorded it (its episode_end record).
struct RecordedEpisodeEnd {
  bool success = false;
  std::string outcome;  ///< to_string of Outcome
  std::uint32_t steps = 0;
};

/// Where a resumed episode (Stack::resume, `dh probe --rest`) was taken up: its evidence holds the rest of
/// another episode from one of its commands.
struct ResumedFrom {
  std::filesystem::path evidence;  ///< the recorded episode
  std::uint32_t command = 0;       ///< K, 0-based in its dispatch order
  std::string command_id;
  std::uint32_t step = 0;          ///< the step it was taken up at
};

struct Recording {
  std::filesystem::path evidence;
  std::optional<ResumedFrom> resumed;  ///< the rest of another episode, which holds the steps before it
  std::string suite, arm, episode_id, build, instruction;
  std::string robot;  ///< the arm on the scene's mount, as requested; empty: the scene's own
  std::set<std::string> predicates;  ///< the goal's text as the seam stated it
  unsigned task = 0;
  std::uint64_t seed = 0;
  std::uint32_t budget_steps = 0, decision_period = 10;
  /// Set when the episode grounded in perception, with its limits on estimates (episode_start).
  std::optional<PerceptionLimits> perception;
  /// The scene estimates the governor took in, in order (scene_estimate records); evidence written
  /// before they were recorded has none.
  std::vector<SceneEstimate> estimates;
  std::vector<RecordedCommand> commands;   ///< in dispatch order
  std::map<std::uint32_t, bool> verdicts;  ///< step -> value of each predicate change
  std::optional<RecordedEpisodeEnd> end;   ///< none: the evidence stops before the episode's end
};

/// Reads the governor's evidence; throws EvidenceError naming the file when it is missing, corrupt, or
/// lacks what a re-run needs.
Recording read_recording(const std::filesystem::path& evidence);

/// A command_status record's end, or nullopt while it says the command is accepted or running. Throws
/// nlohmann::json::exception for a record without its state or step.
std::optional<RecordedEnd> recorded_end(const nlohmann::json& command_status);

cap::Bindings bindings(const nlohmann::json& args);
cap::Theta theta_of(const nlohmann::json& theta);

/// The command as the host core receives it, started at `at` with `theta`, served by `<capability>@<host>`.
cap::CommandStart command_start(const Recording& rec, const RecordedCommand& c, std::uint32_t at,
                                const cap::Theta& theta, const std::string& host);

/// Gives `host` the state it had at the start of command `k`: each earlier command is started on the
/// observation of the state recorded at its start, as the host saw it, and cancelled (its keyframe stays).
/// Leaves `cell` at the last of those states; the caller restores the one it starts from.
void restore_host(cap::HostCore& host, sim::Workcell& cell, const Recording& rec, const sim::StateLog& states,
                  std::size_t k, const std::string& host_name);

}  // namespace dh::inproc
