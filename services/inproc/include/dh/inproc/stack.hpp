// The whole stack in one process, without DDS: the governor's episode machine, the rules planner, every
// capability's skill and the MuJoCo workcell, wired exactly as the services wire them (the seam's
// admission, keyframes at command starts, status on the observation a command ends at). For developing
// skills and rules quickly and for in-process tests; campaign figures come from `dh campaign` over DDS.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dh/cap/descriptor.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/suite.hpp"
#include "dh/gov/episode.hpp"
#include "dh/gov/registry.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {

struct EpisodeOutcome {
  bool success = false;
  std::string outcome, reason;
  std::uint32_t steps = 0, decisions = 0, refusals = 0;
  std::filesystem::path evidence;
};

class Stack {
 public:
  /// Loads the governor configuration, the arms and every capability descriptor under `config_dir`.
  explicit Stack(const std::filesystem::path& config_dir);
  /// Runs one episode of `task` with `seed` under `arm`; evidence goes to `evidence` (JSON lines).
  EpisodeOutcome run(const TaskDef& task, std::uint64_t seed, const std::string& arm,
                     const std::filesystem::path& evidence);
  /// Replaces a capability's θ (as `dh swap --library` would with a new descriptor).
  void set_parameters(const std::string& capability, const cap::Theta& theta);

 private:
  sim::Workcell& cell_for(const TaskDef& task);

  gov::GovernorConfig config_;
  std::map<std::string, ArmSpec> arms_;
  std::map<std::string, cap::CapabilityDef> defs_;
  gov::Registry registry_;
  std::map<std::string, std::unique_ptr<sim::Workcell>> cells_;  ///< by scene key
};

}  // namespace dh::inproc
