// The governor's core: one EpisodeMachine per channel, the registry of announced capability instances,
// readiness, and the rules around requests (a redelivered request, a busy channel, a refused request, an
// observation that arrives before its request). DDS-free: events come in with the time passed in, effects
// go out per channel. Its DDS shell (node/governor_node.cpp) and the in-process bus (services/inproc) run
// this same class, so a request is handled the same way on both.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/arms.hpp"
#include "dh/gov/episode.hpp"
#include "dh/gov/live.hpp"

namespace dh::gov {

/// What a client asks for (idl EpisodeRequest), as plain data.
struct EpisodeRequest {
  std::uint32_t channel = 0;
  std::string episode_id, instruction;
  std::string arm;  ///< empty: "full"
  std::string suite, cell;
  std::string robot;  ///< the arm on the scene's mount (a robot profile); empty: the scene's own
  std::uint32_t task = 0;
  std::uint64_t seed = 0;
  std::uint32_t budget_steps = 0;
  std::string library_version;
  std::map<std::string, std::map<std::string, double>> library;  ///< θ by capability
  std::map<std::string, std::uint32_t> library_costs;            ///< cost under that θ, by capability
  std::optional<std::uint32_t> decision_period;
  std::optional<std::string> grounding;
  std::optional<PerceptionLimits> perception;
  PlannerErrorRates planner_errors;  ///< the slow brain's injected errors (none by default)
  std::vector<GoalTerm> goal;        ///< the task's goal, for the verdict from perception
  std::optional<Verifier> verifier = Verifier::Oracle;  ///< none: a code this governor does not know
  /// Where its evidence goes; empty: runs/evidence/<episode>.jsonl (the in-process bus names its own).
  std::filesystem::path evidence;
};

/// What one event asks the shell to carry out for one channel's episode. The shell carries out the cancel,
/// the lease, the command, the plan request and the result in this order, as the machine produced them.
struct ChannelEffects {
  std::uint32_t channel = 0;
  std::string episode_id;
  Effects fx;
  std::string cancel_instance;     ///< the instance fx.cancel_command was dispatched to
  std::filesystem::path evidence;  ///< with fx.end: the episode's evidence ("" for a request refused unrecorded)
};
using CoreEffects = std::vector<ChannelEffects>;

struct CoreSettings {
  std::filesystem::path runs;  ///< evidence goes to runs/evidence/
  /// Readiness: until then a request waits (on_tick retries it) for every capability it may dispatch to;
  /// after it, an episode starts with what there is and its evidence names what was missing.
  Clock::time_point ready_by;
  /// A running episode's lease is produced again this often, so that the seam hears a live governor also
  /// while no step (and so no renewal) comes; unset: never (the in-process bus needs no keep-alive).
  std::optional<Clock::duration> lease_rewrite;
};

class GovernorCore {
 public:
  GovernorCore(GovernorConfig config, std::map<std::string, ArmSpec> arms, CoreSettings settings);

  CoreEffects on_request(const EpisodeRequest& r, Clock::time_point now);
  CoreEffects on_observation(Observation obs, Clock::time_point now);
  CoreEffects on_advice(std::uint32_t channel, const std::string& episode, const Advice& a, Clock::time_point now);
  CoreEffects on_status(std::uint32_t channel, const std::string& episode, const CommandStatus& s,
                        Clock::time_point now);
  CoreEffects on_scene_estimate(std::uint32_t channel, const SceneEstimate& e, Clock::time_point now);
  void on_verdict(std::uint32_t channel, const std::string& episode, std::uint32_t step,
                  const std::string& predicate, bool value);
  CoreEffects on_seam_event(std::uint32_t channel, const std::string& episode, const SeamEvent& e,
                            Clock::time_point now);

  /// An instance announced itself (again): it is alive, and draining if it says so.
  void on_announce(const CapabilityInfo& info);
  /// An instance's liveliness changed; a lost one ends the commands it runs on every channel.
  CoreEffects on_liveliness(const std::string& instance, bool alive, Clock::time_point now);
  /// A command on the command topic that this governor did not write: recorded in the evidence of the
  /// channel's running episode. Returns why it is not obeyed.
  std::string on_foreign_command(std::uint32_t channel, const std::string& episode, const std::string& command_id,
                                 const std::string& capability);

  /// Retries requests waiting for readiness, ends waits that ran out, and rewrites running leases.
  CoreEffects on_tick(Clock::time_point now);

  /// Resumes an episode on `channel` from the snapshot taken when its command in flight was dispatched
  /// (the probe's rest of an episode): the machine in that state, writing to `evidence`, going on under
  /// `library` with the command in flight given `budget_steps`; returns that command's lease and start,
  /// to be carried out again. Throws std::invalid_argument for a snapshot that cannot be restored,
  /// std::logic_error for a busy channel or a snapshot without a command in flight.
  CoreEffects resume(std::uint32_t channel, const MachineSnapshot& snapshot, const std::filesystem::path& evidence,
                     const std::string& library_version,
                     const std::map<std::string, std::map<std::string, double>>& library,
                     const std::map<std::string, std::uint32_t>& library_costs, std::uint32_t budget_steps,
                     Clock::time_point now);
  /// Drops the channel's episode without an end; its evidence stays as written. For a caller whose own
  /// error cut the episode short (the in-process bus), so that the channel is not busy for the next one.
  void forget(std::uint32_t channel) { channels_.erase(channel); }

  /// Each channel whose episode's state is news for a live view (live.hpp), once; the shell writes them
  /// on rt/dh/evidence.
  std::vector<LiveState> take_live();

  /// When the channel's running episode next acts on its own (on_tick at or after it); unset when none runs.
  std::optional<Clock::time_point> deadline(std::uint32_t channel) const;
  const Registry& registry() const { return registry_; }

 private:
  struct Channel {
    std::unique_ptr<EvidenceWriter> evidence;
    std::unique_ptr<EpisodeMachine> machine;
    /// The simulator answers a request with its first observation, and perception with its first
    /// estimate; either can arrive before the request does and is kept until it comes.
    std::optional<Observation> early;
    std::optional<SceneEstimate> early_scene;
    std::optional<Lease> lease;  ///< the last lease produced for the running episode
    Clock::time_point lease_written;
    std::map<std::string, std::string> instance_of;  ///< the episode's commands: id -> instance
  };

  EpisodeMachine* running(std::uint32_t channel, const std::string& episode);
  bool known(const Channel& ch, const std::string& episode) const;
  /// Wraps a machine's effects for the shell and notes what they change (lease, dispatches, the end).
  void emit(std::uint32_t channel, Effects fx, Clock::time_point now, CoreEffects& out);
  void refuse(const EpisodeRequest& r, const std::string& why, const std::filesystem::path& evidence,
              CoreEffects& out);
  void finished(const std::string& episode);

  GovernorConfig config_;
  std::map<std::string, ArmSpec> arms_;
  CoreSettings settings_;
  Registry registry_;
  std::map<std::uint32_t, Channel> channels_;
  std::vector<std::string> done_;                   ///< the last episodes ended, for redeliveries
  std::vector<EpisodeRequest> held_;                ///< requests waiting for readiness
  std::map<std::uint32_t, LiveTracker> live_;       ///< per channel, fed by its episode's evidence
};

}  // namespace dh::gov
