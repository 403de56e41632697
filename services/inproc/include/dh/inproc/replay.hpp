// Replay: an episode re-run in process from its evidence (<episode>.jsonl, the governor's records), its
// step log (<episode>.steps) and its state log (<episode>.states, both the seam's). The workcell is reset
// to the recorded task and seed, or with --from-command K restored to the state recorded at K's start;
// every recorded action goes through the seam core again, and after each step the physics state's digest
// is compared with the recorded one (and the whole state where the state log has one). The capability host core is fed the same observations and the recorded
// commands at their recorded steps, so the skills give their actions again, and each is compared, bit for
// bit, with the one the seam applied. The first step that differs is named with the body and the
// quantity (a joint's qpos or qvel, the solver's warm start, an action component, ...).
//
// Before it runs, the replay compares fingerprints: the build (commit and diff) that recorded it, the
// compiled model's hash (scene, robot, assets), MuJoCo's version, the suite's instruction, budget and goal
// for the task, and every grounded command's θ against configs/library. A difference refuses the replay (FingerprintMismatch),
// unless drift is allowed; then it is reported and the replay runs anyway.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/inproc/recording.hpp"

namespace dh::inproc {

struct ReplayOptions {
  std::filesystem::path config_dir;          ///< suites, scenes, governor.yaml
  std::filesystem::path library_dir;         ///< the descriptors whose θ is compared (default config_dir/library)
  std::optional<std::uint32_t> from_command;  ///< K: restore the state at the K-th dispatched command's
                                             ///< start (0-based) and replay its actions, to its last one
  bool allow_drift = false;                  ///< run despite differing fingerprints, and say which
  /// Sees the cell in each replayed step's state (the first one included), after it was compared: a
  /// film renders it (dh film).
  std::function<void(std::uint32_t step, const sim::Workcell& cell)> on_step;
};

struct ReplayReport {
  std::string episode_id;
  bool identical = false;
  std::uint32_t steps = 0;           ///< steps replayed
  std::uint32_t recorded_steps = 0;  ///< steps in the step log
  std::uint32_t commands = 0;        ///< commands the episode dispatched (--from-command takes 0 to this - 1)
  std::uint32_t from_step = 0;       ///< with from_command: the command's start step, restored
  std::uint32_t states_checked = 0;  ///< recorded whole states compared on the way
  std::optional<Divergence> first_divergence;
  std::uint32_t divergent_steps = 0;        ///< steps whose state or action differed
  std::uint32_t actions_compared = 0;       ///< skill actions given again and compared with the record
  std::vector<std::string> recorded_only;   ///< capabilities whose actions only the record has, and why
  std::vector<std::string> drift;           ///< fingerprints that differ
  bool verdicts_identical = true;           ///< the predicate changed at the recorded steps
};

/// A fingerprint differs and drift is not allowed; what() names each difference.
struct FingerprintMismatch : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Replays the episode of `evidence`. Throws std::runtime_error naming the file for missing or corrupt
/// evidence, FingerprintMismatch as above.
ReplayReport replay(const std::filesystem::path& evidence, const ReplayOptions& options);

nlohmann::json to_json(const ReplayReport& r);

}  // namespace dh::inproc
