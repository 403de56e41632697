// The capability host's core: the one place a skill is driven. It grounds a command at the capability
// (θ, the skill's own check), starts it with the episode's keyframes, asks it for one action per
// observation, spends the command budget, and reports the command's state. No DDS: the host process
// (host.cpp) runs it over DDS, the in-process bus (dh/inproc/bus.hpp) runs it in lock-step; both feed it
// the same events with the time passed in and publish the effects it returns.
//
// Ports (what the shells connect; README.md lists them, a test checks the list):
//   in   rt/dh/command          dh::msg::Command        START / CANCEL addressed to one of its instances;
//                                                       every START on a channel supersedes what runs there
//   in   rt/dh/observation      dh::msg::Observation    one per step; one action answers it
//   in   rt/dh/perception/scene dh::msg::SceneEstimate  estimates for commands grounded in perception
//   out  rt/dh/action           dh::msg::Action         the action for the observation's step
//   out  rt/dh/command/status   dh::msg::CommandStatus  accepted, refused, running, completed, failed,
//   expired,
//                                                       cancelled, with the reason
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dh/cap/skill.hpp"
#include "dh/common/command.hpp"
#include "dh/common/observation.hpp"
#include "dh/common/perceived_world.hpp"
#include "dh/common/ports.hpp"
#include "dh/common/robot_contract.hpp"

namespace dh::cap {

using Clock = std::chrono::steady_clock;

/// The world a command's skill moves in: the observation's object poses, or the perception service's.
enum class Grounding { State, Perception };

struct CommandStart {
  std::uint32_t channel = 0;
  std::string episode_id, command_id, capability, instance;
  Bindings args;
  Theta theta;  ///< the θ of the episode's library version
  std::uint32_t start_step = 0, budget_steps = 0;
  std::uint32_t decision_period = robot::kDecisionPeriodSteps;  ///< progress is reported at least this often (steps)
  Grounding grounding = Grounding::State;
  PerceptionLimits perception{};  ///< the episode's limits on estimates (grounding Perception)
};

struct CommandCancel {
  std::uint32_t channel = 0;
  std::string episode_id, command_id, instance;
};

struct StatusReport {
  std::uint32_t channel = 0;
  std::string episode_id, command_id, instance;
  CommandState state = CommandState::Running;
  std::string reason, stage;
  std::uint32_t step = 0, steps_used = 0;
  double progress = 0;
  FailureCode failure = FailureCode::None;  ///< why it failed (Failed only)
  std::uint32_t planned_steps = 0;          ///< SkillStep::planned_steps (Running only)
};

struct ActionOut {
  std::uint32_t channel = 0;
  std::string episode_id, command_id;
  std::uint32_t step = 0;  ///< the step of the observation it answers
  std::array<double, 7> a{};
  std::uint32_t frames = 0;  ///< under perception grounding: the estimates its world had taken in
};

/// What one event made the core do, in order: statuses first (an end is reported before any new action).
struct HostEffects {
  std::vector<StatusReport> statuses;
  std::vector<ActionOut> actions;
  void append(HostEffects other);
};

/// One capability the core serves, as one instance.
struct ServedCapability {
  CapabilityDef def;
  std::string instance;  ///< capability@host:pid over DDS, capability@inproc in process
};

class HostCore {
 public:
  /// The perception limits come with each command (the episode's); a channel's perceived world takes in
  /// frames with the defaults (PerceptionLimits{}) until its episode's first command grounded in perception.
  explicit HostCore(const std::vector<ServedCapability>& served);

  static const Ports& ports();
  /// Serves one more capability instance (or replaces the one of the same instance name).
  void serve(ServedCapability s);

  HostEffects on_start(const CommandStart& c, Clock::time_point now);
  HostEffects on_cancel(const CommandCancel& c);
  /// The governor's lease for a channel's command: the command may spend up to `budget_until_step` when that
  /// is more than its budget (the governor raised it for a plan longer than the cost model).
  void on_lease(std::uint32_t channel, const std::string& episode_id, const std::string& command_id,
                std::uint32_t budget_until_step);
  HostEffects on_observation(const Observation& obs, Clock::time_point now);
  HostEffects on_scene_estimate(std::uint32_t channel, const SceneEstimate& e, Clock::time_point now);
  /// A resumed episode's perceived world on `channel`, as its governor's snapshot holds it: what the
  /// estimates before the resumed step left (the host takes in the same estimates and observations).
  void restore_world(std::uint32_t channel, PerceivedWorld world) {
    worlds_.insert_or_assign(channel, std::move(world));
  }
  /// Commands waiting for a frame past the perception limit give up.
  HostEffects on_tick(Clock::time_point now);

  /// From now on new commands are refused (being replaced or stopped); running ones go on.
  void drain() { draining_ = true; }
  bool draining() const { return draining_; }
  std::size_t running() const { return running_.size(); }
  /// The tool poses recorded at command starts with an empty hand in the channel's current episode.
  const std::vector<Keyframe>& keyframes(std::uint32_t channel) const;
  /// The instance serving `capability`, or null.
  const ServedCapability* serving(const std::string& capability) const;

 private:
  struct Running {
    CommandStart command;
    const ServedCapability* served = nullptr;
    std::unique_ptr<Skill> skill;  ///< set once the command's start-step observation arrived
    std::uint32_t steps_used = 0;
    std::optional<std::uint32_t> last_step;  ///< the step last answered: each step is answered once
    std::string stage = "pending";
    /// Set while a perceived command waits for a fresh scene estimate (sending no action holds the
    /// lock-stepped channel too, as a robot pauses for its cameras).
    std::optional<Clock::time_point> awaiting_frame_since;
  };
  using RunningMap = std::map<std::uint32_t, Running>;

  const ServedCapability* find(const std::string& instance) const;
  /// The channel's perceived world when it is of `obs`'s episode, or null.
  PerceivedWorld* world_for(const Observation& obs);
  /// Ends the running command `it` as cancelled, with `why`, at the channel's last observed step.
  StatusReport cancel(RunningMap::iterator it, std::string why);
  HostEffects step(RunningMap::iterator it, const Observation& obs, Clock::time_point now);
  /// θ, the skill's check and start on the start step's observation; false when refused.
  bool begin(Running& r, const Observation& obs, HostEffects& fx);
  HostEffects retry_awaiting(std::uint32_t channel, Clock::time_point now);
  void record_keyframe(const CommandStart& c);
  /// Records the keyframe a command start left due, once `obs` is of its start step.
  void take_keyframe(const Observation& obs);
  static StatusReport status(const Running& r, CommandState st, std::string reason, std::uint32_t step,
                             std::uint32_t used, std::string stage = "", double progress = 0,
                             FailureCode failure = FailureCode::None);

  std::deque<ServedCapability> served_;  ///< a deque: running commands point into it while more are served
  RunningMap running_;
  std::map<std::uint32_t, Observation> last_obs_;
  std::map<std::uint32_t, std::vector<Keyframe>> keyframes_;
  struct KeyframeDue {
    std::string episode_id;
    std::uint32_t step = 0;
  };
  std::map<std::uint32_t, KeyframeDue> keyframe_due_;  ///< per channel: the last command start's step
  std::map<std::uint32_t, PerceivedWorld> worlds_;  ///< per channel: its current episode's perceived world
  bool draining_ = false;
};

}  // namespace dh::cap
