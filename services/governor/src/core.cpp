#include "dh/gov/core.hpp"

#include <algorithm>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/gov/config.hpp"

namespace dh::gov {

namespace {

constexpr std::size_t kRemembered = 256;  ///< ended episodes remembered, so a late redelivery is ignored

bool empty(const Effects& fx) {
  return !fx.plan_request && !fx.command && !fx.lease && !fx.cancel_command && !fx.end;
}

/// The machine's state in the evidence, at the episode's start and at each dispatch, after the event's
/// effects were made: what a resumed episode starts from (`waits` is the deployment's, see MachineSnapshot).
void record_snapshot(EvidenceWriter& evidence, const EpisodeMachine& m, const std::string& at, Clock::time_point now) {
  MachineSnapshot s = m.snapshot(now);
  const nlohmann::json& obs = s.state.at("last_obs");
  const std::uint32_t step = obs.is_null() ? 0 : obs.at("step").get<std::uint32_t>();
  evidence.append("governor", "snapshot",
                  {{"at", at}, {"step", step}, {"machine", std::move(s.state)}, {"waits", std::move(s.waits)}});
}

}  // namespace

GovernorCore::GovernorCore(GovernorConfig config, std::map<std::string, ArmSpec> arms, CoreSettings settings)
    : config_(std::move(config)), arms_(std::move(arms)), settings_(std::move(settings)) {}

bool GovernorCore::known(const Channel& ch, const std::string& episode) const {
  return (ch.machine && ch.machine->spec().episode_id == episode) ||
         std::find(done_.begin(), done_.end(), episode) != done_.end();
}

EpisodeMachine* GovernorCore::running(std::uint32_t channel, const std::string& episode) {
  auto it = channels_.find(channel);
  if (it == channels_.end() || !it->second.machine || it->second.machine->spec().episode_id != episode ||
      it->second.machine->ended())
    return nullptr;
  return it->second.machine.get();
}

void GovernorCore::finished(const std::string& episode) {
  done_.push_back(episode);
  if (done_.size() > kRemembered) done_.erase(done_.begin());
}

void GovernorCore::emit(std::uint32_t channel, Effects fx, Clock::time_point now, CoreEffects& out) {
  if (empty(fx)) return;
  Channel& ch = channels_[channel];
  ChannelEffects e{channel, ch.machine->spec().episode_id, std::move(fx), {}, {}};
  if (e.fx.cancel_command) {
    const auto it = ch.instance_of.find(*e.fx.cancel_command);
    if (it != ch.instance_of.end()) e.cancel_instance = it->second;
  }
  if (e.fx.lease) {
    ch.lease = *e.fx.lease;
    ch.lease_written = now;
  }
  if (e.fx.command) {
    ch.instance_of[e.fx.command->command_id] = e.fx.command->instance;
    record_snapshot(*ch.evidence, *ch.machine, e.fx.command->command_id, now);
  }
  if (e.fx.end) {
    e.evidence = ch.evidence->path();
    finished(e.episode_id);
  }
  out.push_back(std::move(e));
}

void GovernorCore::refuse(const EpisodeRequest& r, const std::string& why, const std::filesystem::path& evidence,
                          CoreEffects& out) {
  Effects fx;
  fx.end = EpisodeEnd{false, 0, Outcome::Rejected, why, 0, 0, {}};
  out.push_back({r.channel, r.episode_id, std::move(fx), {}, evidence});
  finished(r.episode_id);
}

CoreEffects GovernorCore::resume(std::uint32_t channel, const MachineSnapshot& snapshot,
                                 const std::filesystem::path& evidence, const std::string& library_version,
                                 const std::map<std::string, std::map<std::string, double>>& library,
                                 const std::map<std::string, std::uint32_t>& library_costs,
                                 std::uint32_t budget_steps, Clock::time_point now) {
  Channel& ch = channels_[channel];
  if (ch.machine && !ch.machine->ended())
    throw std::logic_error("resume: channel " + std::to_string(channel) + " is busy with episode " +
                           ch.machine->spec().episode_id);
  const EpisodeSpec spec = snapshot_spec(snapshot);
  GovernorConfig config;
  try {
    config = for_request(for_arm(config_, find_arm(arms_, spec.arm)), spec);
  } catch (const ConfigError& e) {
    throw std::invalid_argument("the snapshot of " + spec.episode_id + " cannot run here: " + e.what());
  }
  // Made aside and installed once the command is dispatched again: a failure leaves the channel as it was.
  auto writer = std::make_unique<EvidenceWriter>(evidence);
  auto machine = EpisodeMachine::restore(snapshot, channel, config, registry_, *writer, now);
  Effects fx = machine->redispatch(library_version, library, library_costs, budget_steps, now);
  ch = Channel{};
  ch.evidence = std::move(writer);
  ch.machine = std::move(machine);
  CoreEffects out;
  emit(channel, std::move(fx), now, out);
  return out;
}

CoreEffects GovernorCore::on_request(const EpisodeRequest& r, Clock::time_point now) {
  CoreEffects out;
  Channel& ch = channels_[r.channel];
  if (known(ch, r.episode_id)) return out;  // a redelivery
  const std::string arm = r.arm.empty() ? "full" : r.arm;
  EpisodeSpec spec{r.channel,         r.episode_id, r.instruction,     arm,         r.budget_steps,
                   r.library_version, r.library,    r.library_costs, r.decision_period, r.grounding, r.perception,
                   planner_error_seed(r.cell, r.task, r.seed), r.planner_errors, r.goal, r.verifier};
  std::optional<GovernorConfig> episode_config;
  std::string why;
  try {
    episode_config = for_request(for_arm(config_, find_arm(arms_, arm)), spec);
  } catch (const ConfigError& e) {
    why = e.what();
  }
  // Readiness: the episode waits until every capability it may dispatch to has announced an instance that
  // takes commands (they come on discovery, possibly after this governor started), at most until ready_by;
  // then it runs with what there is and its evidence says what was missing. A request that names no
  // library cannot say what it needs: it waits until ready_by.
  if (episode_config && now < settings_.ready_by) {
    const bool waits = spec.library.empty() || !registry_.missing(needed_capabilities(*episode_config, spec)).empty();
    if (waits) {
      held_.push_back(r);
      return out;
    }
  }
  if (ch.machine && !ch.machine->ended()) {
    // One client's request must not preempt another's episode.
    refuse(r, "channel " + std::to_string(r.channel) + " is busy with episode " + ch.machine->spec().episode_id, {},
           out);
    return out;
  }
  const std::filesystem::path path =
      r.evidence.empty() ? paths::evidence_file(settings_.runs, r.episode_id, ".jsonl") : r.evidence;
  ch.machine.reset();
  ch.lease.reset();
  ch.instance_of.clear();
  ch.evidence = std::make_unique<EvidenceWriter>(path);
  LiveTracker& live = live_[r.channel] = LiveTracker(r.channel, r.episode_id, path);
  ch.evidence->set_tap([&live](const std::string& kind, const nlohmann::json& record) { live.record(kind, record); });
  record_request(*ch.evidence, r.suite, r.task, r.seed, r.cell, r.arm, r.robot, r.planner_errors);
  if (!episode_config) {
    // Answered at once, so the client and the simulator channel do not wait for a deadline.
    ch.evidence->append("governor", "episode_rejected", {{"reason", why}});
    refuse(r, why, path, out);
    return out;
  }
  ch.machine = std::make_unique<EpisodeMachine>(std::move(spec), *episode_config, registry_, *ch.evidence, now);
  record_snapshot(*ch.evidence, *ch.machine, "episode_start", now);
  if (ch.early && ch.early->episode_id == r.episode_id) {
    Observation first = std::move(*ch.early);
    ch.early.reset();
    for (auto& e : on_observation(std::move(first), now)) out.push_back(std::move(e));
  }
  if (ch.early_scene && ch.early_scene->episode_id == r.episode_id) {
    const SceneEstimate scene = std::move(*ch.early_scene);
    ch.early_scene.reset();
    for (auto& e : on_scene_estimate(r.channel, scene, now)) out.push_back(std::move(e));
  }
  return out;
}

CoreEffects GovernorCore::on_observation(Observation obs, Clock::time_point now) {
  CoreEffects out;
  const std::uint32_t channel = obs.channel;
  if (auto* m = running(channel, obs.episode_id)) {
    emit(channel, m->on_observation(std::move(obs), now), now, out);
    return out;
  }
  Channel& ch = channels_[channel];
  if (!known(ch, obs.episode_id)) ch.early = std::move(obs);
  return out;
}

CoreEffects GovernorCore::on_advice(std::uint32_t channel, const std::string& episode, const Advice& a,
                                    Clock::time_point now) {
  CoreEffects out;
  if (auto* m = running(channel, episode)) emit(channel, m->on_advice(a, now), now, out);
  return out;
}

CoreEffects GovernorCore::on_status(std::uint32_t channel, const std::string& episode, const CommandStatus& s,
                                    Clock::time_point now) {
  CoreEffects out;
  if (auto* m = running(channel, episode)) emit(channel, m->on_status(s, now), now, out);
  return out;
}

CoreEffects GovernorCore::on_scene_estimate(std::uint32_t channel, const SceneEstimate& e, Clock::time_point now) {
  CoreEffects out;
  if (auto* m = running(channel, e.episode_id)) {
    emit(channel, m->on_scene_estimate(e, now), now, out);
    return out;
  }
  Channel& ch = channels_[channel];
  if (!known(ch, e.episode_id)) ch.early_scene = e;
  return out;
}

void GovernorCore::on_verdict(std::uint32_t channel, const std::string& episode, std::uint32_t step,
                              const std::string& predicate, bool value) {
  if (auto* m = running(channel, episode)) m->on_verdict(step, predicate, value);
}

CoreEffects GovernorCore::on_seam_event(std::uint32_t channel, const std::string& episode, const SeamEvent& e,
                                        Clock::time_point now) {
  CoreEffects out;
  if (auto* m = running(channel, episode)) emit(channel, m->on_seam_event(e), now, out);
  return out;
}

void GovernorCore::on_announce(const CapabilityInfo& info) { registry_.announce(info); }

CoreEffects GovernorCore::on_liveliness(const std::string& instance, bool alive, Clock::time_point now) {
  CoreEffects out;
  registry_.set_alive(instance, alive);
  if (alive) return out;
  for (auto& [id, ch] : channels_)
    if (ch.machine && !ch.machine->ended()) emit(id, ch.machine->on_capability_lost(instance, now), now, out);
  return out;
}

std::string GovernorCore::on_foreign_command(std::uint32_t channel, const std::string& episode,
                                             const std::string& command_id, const std::string& capability) {
  const std::string why = "command '" + command_id + "' for capability '" + capability +
                          "' was not issued by this governor" +
                          (registry_.known(capability) ? std::string() : "; no such capability is announced");
  const auto it = channels_.find(channel);
  if (it != channels_.end() && it->second.machine && !it->second.machine->ended())
    it->second.evidence->append("governor", "foreign_command",
                                {{"command_id", command_id}, {"capability", capability}, {"episode_id", episode},
                                 {"reason", why}});
  return why;
}

CoreEffects GovernorCore::on_tick(Clock::time_point now) {
  CoreEffects out;
  if (!held_.empty()) {  // each is held again while it still waits
    const auto held = std::move(held_);
    held_.clear();
    for (const auto& r : held)
      for (auto& e : on_request(r, now)) out.push_back(std::move(e));
  }
  for (auto& [id, ch] : channels_)
    if (ch.machine && !ch.machine->ended()) emit(id, ch.machine->on_tick(now), now, out);
  if (!settings_.lease_rewrite) return out;
  for (auto& [id, ch] : channels_) {
    if (!ch.lease || !ch.machine || ch.machine->ended() || now - ch.lease_written < *settings_.lease_rewrite) continue;
    Effects fx;
    fx.lease = *ch.lease;
    out.push_back({id, ch.machine->spec().episode_id, std::move(fx), {}, {}});
    ch.lease_written = now;
  }
  return out;
}

std::vector<LiveState> GovernorCore::take_live() {
  std::vector<LiveState> out;
  for (auto& [channel, tracker] : live_)
    if (auto s = tracker.take()) out.push_back(std::move(*s));
  return out;
}

std::optional<Clock::time_point> GovernorCore::deadline(std::uint32_t channel) const {
  const auto it = channels_.find(channel);
  if (it == channels_.end() || !it->second.machine || it->second.machine->ended()) return std::nullopt;
  return it->second.machine->deadline();
}

}  // namespace dh::gov
