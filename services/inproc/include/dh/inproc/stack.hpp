// The whole stack in one process, without DDS, on the in-process bus (bus.hpp): the governor's core
// (gov::GovernorCore, as dh_governor runs it), the rules planner, the capability host core serving every
// capability, the seam over a MuJoCo workcell and, for arms that ground from perception, the perception
// service's core (bus_perception.hpp) — the cores the services run, in lock-step. For
// developing skills and rules, training and in-process tests; campaign figures come from `dh campaign`
// over DDS.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/host_core.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/suite.hpp"
#include "dh/gov/core.hpp"
#include "dh/inproc/bus_perception.hpp"
#include "dh/inproc/recording.hpp"
#include "dh/planner/core.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/workcell_cache.hpp"

namespace dh::inproc {

/// Taps into the control loop: `on_action` sees each observation with the action the running capability
/// gave for it (demonstration recording); `perturb` may change the action the workcell then applies
/// (noise injection), after it was seen.
struct StepTap {
  std::function<void(const Observation&, const std::string& capability, const std::array<double, 7>&)> on_action;
  std::function<void(std::array<double, 7>&)> perturb;
  /// Sees the cell after each applied action, in the state of the step it led to.
  std::function<void(std::uint32_t step, const sim::Workcell& cell)> on_step;
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
  /// What a resumed episode starts from: a recorded episode (recording.hpp) at its command `command`'s start.
  struct Resume {
    const Recording& recording;
    const sim::StateLog& states;  ///< the recording's state log
    const TaskDef& task;          ///< the recorded task
    std::uint32_t command = 0;    ///< K, 0-based in dispatch order
    /// The library the episode goes on under; none: the one it recorded.
    std::optional<cap::LibraryTheta> library;
    std::uint32_t budget_steps = 0;  ///< command K's budget
  };
  /// Runs the rest of a recorded episode from command K's start (the probe's rest of an episode): the
  /// workcell restored to the state recorded there, the capability host core to the keyframes the earlier
  /// commands left, the governor's core to its snapshot at K's dispatch; K is dispatched again and the
  /// episode runs to its end as `run` runs one. Evidence from K on goes to `evidence`. Throws
  /// EvidenceError for a recording without a state or a snapshot at K, std::invalid_argument for a K out
  /// of range or a snapshot that cannot be restored.
  EpisodeOutcome resume(const Resume& from, const std::filesystem::path& evidence, const StepTap& tap = {});
  /// The planner-error rates every later episode's planner runs with (none by default).
  void set_planner_errors(const PlannerErrorRates& rates) { planner_errors_ = rates; }
  /// The arm every later episode of `run` puts on the scene's mount (a robot profile's name); empty, the
  /// default: the scene's own. A resumed episode runs on the arm it recorded.
  void set_robot(std::string robot) { robot_ = std::move(robot); }
  /// Serves one more capability, described by `library_dir`/<name>.yaml, e.g. vla_act with a loaded policy.
  void add_capability(cap::CapabilityDef def, const std::filesystem::path& library_dir);

 private:
  static constexpr std::uint32_t kChannel = 0;  ///< every episode's
  /// One episode in flight: what `drive` takes from `run` or `resume`.
  struct Episode {
    sim::Workcell& cell;
    sim::SeamCore& seam;
    Observation obs;                   ///< the seam's first observation
    cap::Clock::time_point now;
    std::string episode_id;
    std::filesystem::path evidence;
    const StepTap& tap;
    bool governor_saw_obs = false;     ///< a resumed governor decided on `obs` before its snapshot
    BusPerception* perception = nullptr;  ///< set when the episode grounds from perception
  };
  /// The workcell of `task` and `seed` for an episode; one that perceives is compiled with the RGB-D
  /// cameras, and perception is made ready for it.
  sim::Workcell& cell_for(const TaskDef& task, std::uint64_t seed, const std::string& robot, bool perceives);
  /// Drives an episode to its end over the bus; `first` gives the governor's effects that start it.
  EpisodeOutcome drive(Episode episode, const std::function<gov::CoreEffects()>& first);

  std::filesystem::path config_dir_;
  gov::GovernorConfig config_;  ///< configs/governor.yaml: the arms' settings the requests carry
  std::map<std::string, ArmSpec> arms_;
  gov::GovernorCore governor_;  ///< every episode on channel 0
  std::vector<cap::ServedCapability> served_;  ///< every capability's instance "<name>@inproc"
  cap::HostCore host_;
  planner::PlannerCore planner_{planner::PlannerCore::Backend::Rules};
  cap::LibraryTheta library_;
  std::uint64_t runs_ = 0;  ///< episodes run, for unique episode ids
  PlannerErrorRates planner_errors_;
  std::string robot_;
  sim::WorkcellCache cells_;
  std::unique_ptr<BusPerception> perception_;       ///< made for the first episode that perceives
  std::unique_ptr<sim::WorkcellCache> seen_cells_;  ///< its workcells, with the RGB-D cameras
};

}  // namespace dh::inproc
