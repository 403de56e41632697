// The in-process lock-step bus: the same cores the services run over DDS, wired in one process and one
// thread, in a fixed order, on a clock that advances 50 ms per control step. What it runs is what the
// product runs: the capability host core drives every skill; the seam admits every action (lease, budgets,
// step) before the physics applies it.
//
// Per step: the seam core's observation goes to the governor's core first (its decision, lease, command or
// cancel take effect at once, as within one control step over DDS), then to the capability host core,
// whose action the seam core admits and applies, exactly as the simulator worker's seam does over DDS. When nothing can move (no action, no end), the clock jumps to
// the governor's next deadline, as a stalled channel would wait for it over DDS.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dh/cap/host_core.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {

/// The bus clock: an episode starts at the epoch, each control step adds 50 ms (the host core's and the
/// seam core's clocks are both std::chrono::steady_clock).
inline cap::Clock::time_point step_time(std::uint32_t step) {
  return cap::Clock::time_point{} + std::chrono::milliseconds(50) * step;
}

/// The seam's settings on the bus: a lease reaches the seam within its step (one thread), so an action of
/// a command without one is refused at once instead of after a grace period.
inline constexpr sim::SeamSettings kBusSeam{std::chrono::milliseconds(0), std::chrono::milliseconds(60000),
                                            std::chrono::milliseconds(1000)};

struct CommandOutcome {
  CommandState state = CommandState::Running;
  FailureCode failure = FailureCode::None;
  std::string reason, stage;
  std::uint32_t steps = 0;  ///< steps the command spent
  bool goal = false;        ///< the task's goal held at some step while it ran
  int safety_events = 0;
  int speed_limited = 0;  ///< steps in which the controller braked an over-fast joint (docs/controller.md)
  Observation last;
};

/// Commands one at a time on one workcell through the host core and the seam, with the caller in the
/// governor's place: each command is leased for its whole budget. For skill tests and probes.
class CommandRunner {
 public:
  CommandRunner(sim::Workcell& cell, cap::HostCore& host, std::uint32_t budget_steps);

  /// A new episode on the cell as it is now (reset it first for a seeded start).
  void begin_episode(const std::string& episode_id);
  /// Resumes a recorded episode from the state recorded at `from` (a command's start), checking `predicate`.
  void resume_episode(const std::string& episode_id, const std::string& predicate, const sim::StateRecord& from);
  /// Runs `capability` with `args` under `theta` until it ends or its `budget_steps` run out.
  CommandOutcome run(const std::string& capability, const cap::Bindings& args, const cap::Theta& theta,
                     std::uint32_t budget_steps);
  /// Runs `c` from the current step (its start_step is set to it) until it ends or its budget runs out.
  CommandOutcome run(cap::CommandStart c);

  /// Called after each applied action with the step it led to, the cell in that step's state.
  std::function<void(std::uint32_t step)> after_step;

 private:
  sim::Workcell& cell_;
  cap::HostCore& host_;
  std::uint32_t episode_budget_;
  sim::SeamCore seam_{0, kBusSeam};
  int commands_ = 0;
};

}  // namespace dh::inproc
