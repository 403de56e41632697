// The robot seam of one channel, DDS-free: the episode the channel runs, the lease the governor last
// granted, the actions waiting for admission (one per command), the step, abandonment. Events come in with
// the time passed in and effects come out, so the simulator worker's DDS shell, the in-process bus and a
// hardware adapter run the same seam, and unit tests drive it without DDS.
//
// Admission (seam.hpp, admit_action) is by step: an action is applied when the lease of its command covers
// its step. An action that cannot be applied yet is held, never refused for lack of a message that is
// merely late: a lease expired by step waits for its renewal, and a lease writer that went silent (the
// lease topic's deadline) holds every action until it is heard again. Holding stops the robot; the
// governor's deadlines or abandonment end an episode that stays held. Refused at once: a stale or future
// step, a spent budget, a revoked lease; an action of a command with no lease waits the grace period for
// one (a command's first action can overtake its lease), then is refused.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"
#include "dh/common/ports.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/sim/seam.hpp"
#include "dh/sim/seam_cell.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"

namespace dh::sim {

using SeamClock = std::chrono::steady_clock;

struct SeamSettings {
  std::chrono::milliseconds grace{1000};          ///< an action of an unleased command waits this long
  /// No lease, start or applied action this long: the episode is abandoned. A live governor ends an
  /// episode before the 60 s default (its longest wait without leases is 4 refused plans of 10 s,
  /// configs/governor.yaml), so a dead governor is the cause; a model-server planner needs more
  /// (deploy/local_openai.yaml raises --abandon-after-s with it).
  std::chrono::milliseconds abandon_after{60000};
  std::chrono::milliseconds lease_deadline{1000};  ///< the lease topic's deadline (dds.hpp kLeaseDeadlineSec)
};

struct LeaseGrant {
  std::string episode_id, command_id;
  std::uint32_t valid_until_step = 0, budget_until_step = 0;
  bool revoked = false;
};

struct ActionIn {
  std::string episode_id, command_id;
  std::uint32_t step = 0;  ///< the step of the observation it answers
  std::array<double, 7> a{};
  std::uint32_t frames = 0;  ///< the estimates its capability's perceived world had taken in (step log)
  std::string
      from{};  ///< who sent it, as the shell addresses it: the step it leads to is for them (SeamEffects::to)
};

struct VerdictChange {
  std::uint32_t step = 0;
  std::string predicate;
  bool value = false;
};

/// What one event made the seam do, in order: refusals and corrections, then the new step's observation.
struct SeamEffects {
  std::vector<SeamEvent> events;
  std::optional<VerdictChange> verdict;     ///< the task predicate changed at `observation`
  /// The current step again, before anything else: a command starts on it (its first lease came), and its
  /// capability may not have been sent it (the shell sends it to every reader).
  std::optional<Observation> again;
  std::optional<Observation> observation;   ///< a new step: the episode started or an action was applied
  std::string to;  ///< whom `observation` is for: ActionIn::from of the action applied; "" for everyone
  std::optional<std::string> ended;  ///< the seam ended the episode itself (physics failed, abandoned);
                                     ///< an Ended event in `events` says so to the governor
};

class SeamCore {
 public:
  SeamCore(std::uint32_t channel, SeamSettings settings);

  static const Ports& ports();

  /// A new episode on `cell`, already reset to its task and seed. Returns the observation of step 0.
  /// `steps_file`: where the step log goes (step_log.hpp; beside the episode's evidence), or empty for
  /// none; the state log (state_log.hpp) goes beside it, `.states` for `.steps`. The state is recorded
  /// at step 0 and whenever a lease names a command not seen before in the episode: its start.
  SeamEffects start(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps, std::string predicate,
                    SeamClock::time_point now, const std::filesystem::path& steps_file = {});
  /// An episode taken up from a recorded state (a replay or a probe from a command's start): `cell` is
  /// reset to the task and seed, then the state is restored and the seam stands at its step. Nothing is
  /// logged. Returns the observation of that step; the predicate's value there is not a change.
  SeamEffects resume(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps, std::string predicate,
                     const StateRecord& from, SeamClock::time_point now);
  /// The governor ended the episode (or the seam did): the channel goes idle. episode_id() and step()
  /// keep saying what ran last.
  void end();

  SeamEffects on_lease(const LeaseGrant& l, SeamClock::time_point now);
  SeamEffects on_action(const ActionIn& a, SeamClock::time_point now);
  /// The lease topic missed its deadline somewhere: true when this channel's own lease is the silent one.
  bool on_lease_silent(SeamClock::time_point now);
  /// Grace expiries and abandonment.
  SeamEffects on_tick(SeamClock::time_point now);

  bool running() const { return cell_ != nullptr; }
  const std::string& episode_id() const { return episode_; }
  std::uint32_t step() const { return step_; }
  std::uint32_t budget() const { return budget_; }
  const LeaseState& lease() const { return lease_; }
  /// The observation of the current step (the last one the seam gave out).
  const Observation& observation() const { return observation_; }
  std::size_t held() const { return pending_.size(); }
  /// Actions of commands the governor had revoked or handed the lease on from, dropped unrecorded.
  std::size_t stragglers() const { return stragglers_; }
  double physics_s() const { return physics_s_; }  ///< wall time inside the cell's steps this episode
  /// The simulator's own verdict: the first step at which the task's goal held this episode (none: never).
  std::optional<std::uint32_t> goal_step() const { return goal_step_; }

 private:
  struct Pending {
    ActionIn action;
    SeamClock::time_point since;
  };
  /// The episode's fields as at its start, logs closed.
  void begin(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps, std::string predicate,
             SeamClock::time_point now);
  /// Admits what can be admitted, refuses what must be refused, applies at most one action per step.
  SeamEffects admit(SeamClock::time_point now);
  /// The new step's observation (and verdict change), logged with the action that led to it.
  void observe(SeamEffects& fx, const ActionIn* applied);
  /// The seam ends the episode itself: `why` as `ended` and as an Ended event (what the governor reads).
  void ended_by_seam(SeamEffects& fx, std::string why, std::string command_id = {});

  std::uint32_t channel_;
  SeamSettings settings_;
  SeamCell* cell_ = nullptr;
  std::string episode_, predicate_text_;
  std::uint32_t budget_ = 0, step_ = 0;
  LeaseState lease_;
  SeamClock::time_point lease_at_, last_sign_of_life_;
  std::map<std::string, Pending> pending_;  ///< by command id
  Observation observation_;
  std::unique_ptr<StepLogWriter> log_;
  std::unique_ptr<StateLogWriter> states_;
  std::set<std::string> started_;  ///< the commands whose first lease came (whose start the state log holds)
  std::set<std::string> handed_over_;  ///< commands revoked or superseded by another's lease
  std::size_t stragglers_ = 0;
  bool predicate_ = false;
  std::optional<std::uint32_t> goal_step_;
  double physics_s_ = 0;
};

}  // namespace dh::sim
