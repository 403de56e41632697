// The in-process lock-step bus: the same cores the services run over DDS, wired in one process and one
// thread, in a fixed order, on a clock that advances 50 ms per control step. What it runs is what the
// product runs: the capability host core drives every skill; the seam admits every action (lease, budgets,
// step) before the physics applies it.
//
// Per step: the seam's observation goes to the governor's core first (its decision, lease, command or
// cancel take effect at once, as within one control step over DDS), then to the capability host core,
// whose action the seam admits and applies. When nothing can move (no action, no end), the clock jumps to
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
#include "dh/sim/seam.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {

/// The bus clock: an episode starts at the epoch, each control step adds 50 ms.
inline cap::Clock::time_point step_time(std::uint32_t step) {
  return cap::Clock::time_point{} + std::chrono::milliseconds(50) * step;
}

/// One simulator channel in process: the workcell, its step, the lease last granted, and admission.
class SeamChannel {
 public:
  SeamChannel(sim::Workcell& cell, std::uint32_t channel, std::string episode_id, std::uint32_t budget_steps);

  /// The observation of the current step, stamped with channel, episode, step and budget.
  Observation observe() const;
  void on_lease(const sim::LeaseState& lease) { lease_ = lease; }
  /// Admits `a` and, when admitted, applies `applied` (the action itself unless a tap perturbed it) for
  /// one control step. Returns what the seam refused or corrected; `stepped` says whether physics ran.
  std::vector<SeamEvent> apply(const cap::ActionOut& a, const std::array<double, 7>& applied, bool& stepped);

  std::uint32_t step() const { return step_; }
  const std::string& episode_id() const { return episode_; }
  sim::Workcell& cell() { return cell_; }

 private:
  sim::Workcell& cell_;
  std::uint32_t channel_;
  std::string episode_;
  std::uint32_t budget_;
  std::uint32_t step_ = 0;
  sim::LeaseState lease_;
};

struct CommandOutcome {
  CommandState state = CommandState::Running;
  FailureCode failure = FailureCode::None;
  std::string reason, stage;
  std::uint32_t steps = 0;  ///< steps the command spent
  bool goal = false;        ///< the task's goal held at some step while it ran
  int safety_events = 0;
  Observation last;
};

/// Commands one at a time on one workcell through the host core and the seam, with the caller in the
/// governor's place: each command is leased for its whole budget. For skill tests and probes.
class CommandRunner {
 public:
  CommandRunner(sim::Workcell& cell, cap::HostCore& host, std::uint32_t budget_steps);

  /// A new episode on the cell as it is now (reset it first for a seeded start).
  void begin_episode(const std::string& episode_id);
  /// Runs `capability` with `args` under `theta` until it ends or its `budget_steps` run out.
  CommandOutcome run(const std::string& capability, const cap::Bindings& args, const cap::Theta& theta,
                     std::uint32_t budget_steps);

 private:
  sim::Workcell& cell_;
  cap::HostCore& host_;
  std::uint32_t episode_budget_;
  std::optional<SeamChannel> seam_;
  int commands_ = 0;
};

}  // namespace dh::inproc
