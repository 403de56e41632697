// The whole stack in one process, without DDS, on the in-process bus (bus.hpp): the governor's core
// (gov::GovernorCore, as dh_governor runs it), the rules planner, the capability host core serving every
// capability, and the seam over a MuJoCo workcell — the cores the services run, in lock-step. For
// developing skills and rules, training and in-process tests; campaign figures come from `dh campaign`
// over DDS.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/host_core.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/suite.hpp"
#include "dh/gov/core.hpp"
#include "dh/planner/core.hpp"
#include "dh/sim/workcell_cache.hpp"

namespace dh::inproc {

/// Taps into the control loop: `on_action` sees each observation with the action the running capability
/// gave for it (demonstration recording); `perturb` may change the action the workcell then applies
/// (noise injection), after it was seen.
struct StepTap {
  std::function<void(const Observation&, const std::string& capability, const std::array<double, 7>&)> on_action;
  std::function<void(std::array<double, 7>&)> perturb;
};

struct EpisodeOutcome {
  bool success = false;
  Outcome outcome = Outcome::GaveUp;
  std::string reason;
  std::uint32_t steps = 0, decisions = 0, refusals = 0;
  std::filesystem::path evidence;
};

class Stack {
 public:
  /// Loads the governor configuration and the arms under `config_dir`, and every capability descriptor
  /// under `library_dir` (default `config_dir`/library, as `dh campaign` sends it); its episodes run that
  /// library.
  explicit Stack(const std::filesystem::path& config_dir, const std::filesystem::path& library_dir = {});
  /// Runs one episode of `task` with `seed` under `arm`; evidence goes to `evidence` (JSON lines).
  EpisodeOutcome run(const TaskDef& task, std::uint64_t seed, const std::string& arm,
                     const std::filesystem::path& evidence, const StepTap& tap = {});
  /// The planner-error rates every later episode's planner runs with (none by default).
  void set_planner_errors(const PlannerErrorRates& rates) { planner_errors_ = rates; }
  /// Serves one more capability, described by `library_dir`/<name>.yaml, e.g. vla_act with a loaded policy.
  void add_capability(cap::CapabilityDef def, const std::filesystem::path& library_dir);

 private:

  gov::GovernorCore governor_;  ///< every episode on channel 0
  cap::HostCore host_;  ///< every capability's instance "<name>@inproc"
  planner::PlannerCore planner_{planner::PlannerCore::Backend::Rules};
  cap::LibraryTheta library_;
  std::uint64_t runs_ = 0;  ///< episodes run, for unique episode ids
  PlannerErrorRates planner_errors_;
  sim::WorkcellCache cells_;
};

}  // namespace dh::inproc
