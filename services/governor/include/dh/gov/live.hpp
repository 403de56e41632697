// What a channel's episode is doing now, folded from the records the governor's core writes into its
// evidence, so a live view (rt/dh/evidence, dh view) never says what the evidence file does not. It is
// news when something other than an observation was recorded, or the step moved on by a decision period,
// since it was last taken: a few samples per second and channel at most.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace dh::gov {

struct LiveState {
  std::uint32_t channel = 0;
  std::string episode_id, arm, cell;
  std::uint32_t task = 0;
  std::uint64_t seed = 0;
  std::uint32_t step = 0, budget_steps = 0;
  std::string capability;        ///< the command in control, "" when none
  std::string decision, reason;  ///< the last decision (or refusal) and why
  bool ended = false;
  std::string outcome;           ///< with ended
  std::filesystem::path evidence;
};

class LiveTracker {
 public:
  LiveTracker() = default;
  LiveTracker(std::uint32_t channel, std::string episode_id, std::filesystem::path evidence);
  /// Folds in one evidence record (its kind and fields, as EvidenceWriter::append got them).
  void record(const std::string& kind, const nlohmann::json& fields);
  /// The state when it is news (see above), once.
  std::optional<LiveState> take();

 private:
  LiveState state_;
  std::map<std::string, std::string> capability_of_;  ///< command id -> capability
  std::uint32_t period_ = 10, taken_step_ = 0;
  bool news_ = false;
};

}  // namespace dh::gov
