#include "dh/cap/host_core.hpp"

#include <stdexcept>


namespace dh::cap {
namespace {

std::vector<std::string> bound_entities(const CommandStart& c) {
  std::vector<std::string> e;
  for (const auto& [role, entity] : c.args) e.push_back(entity);
  return e;
}

}  // namespace

void HostEffects::append(HostEffects other) {
  for (auto& s : other.statuses) statuses.push_back(std::move(s));
  for (auto& a : other.actions) actions.push_back(std::move(a));
}

HostCore::HostCore(const std::vector<ServedCapability>& served) : served_(served.begin(), served.end()) {}

const Ports& HostCore::ports() {
  static const Ports p{
      in_port<port::Command>("START / CANCEL for one of its instances"),
      in_port<port::Observation>(
          "the steps of its commands, every command's start, every step when perceiving"),
      in_port<port::SceneEstimate>("estimates for commands grounded in perception"),
      in_port<port::Lease>("the running command's budget, raised when its skill plans longer than its cost"),
      out_port<port::Action>("the action answering an observation"),
      out_port<port::CommandStatus>("the command's state and reason"),
      out_port<port::Announce>(
          "one per capability served, again with `draining` set on drain; liveliness asserted from the loop"),
  };
  return p;
}

void HostCore::serve(ServedCapability s) {
  for (auto& x : served_)
    if (x.instance == s.instance) {
      x = std::move(s);
      return;
    }
  served_.push_back(std::move(s));
}

const std::vector<Keyframe>& HostCore::keyframes(std::uint32_t channel) const {
  static const std::vector<Keyframe> none;
  const auto it = keyframes_.find(channel);
  return it == keyframes_.end() ? none : it->second;
}

const ServedCapability* HostCore::find(const std::string& instance) const {
  for (const auto& s : served_)
    if (s.instance == instance) return &s;
  return nullptr;
}

const ServedCapability* HostCore::serving(const std::string& capability) const {
  for (const auto& s : served_)
    if (s.def.name == capability) return &s;
  return nullptr;
}

PerceivedWorld* HostCore::world_for(const Observation& obs) {
  const auto w = worlds_.find(obs.channel);
  return w != worlds_.end() && w->second.episode() == obs.episode_id ? &w->second : nullptr;
}

void HostCore::on_lease(std::uint32_t channel, const std::string& episode_id, const std::string& command_id,
                        std::uint32_t budget_until_step) {
  const auto it = running_.find(channel);
  if (it == running_.end()) return;
  CommandStart& c = it->second.command;
  if (c.episode_id != episode_id || c.command_id != command_id || budget_until_step <= c.start_step) return;
  c.budget_steps = std::max(c.budget_steps, budget_until_step - c.start_step);
}

StatusReport HostCore::cancel(RunningMap::iterator it, std::string why) {
  const auto o = last_obs_.find(it->first);
  StatusReport s = status(it->second, CommandState::Cancelled, std::move(why),
                          o != last_obs_.end() ? o->second.step : 0, it->second.steps_used);
  running_.erase(it);
  return s;
}

HostEffects HostCore::on_start(const CommandStart& c, Clock::time_point now) {
  HostEffects fx;
  record_keyframe(c);
  // A newer command on the channel supersedes whatever runs there (its CANCEL may have been overwritten
  // on the channel's key before it was read).
  if (auto it = running_.find(c.channel);
      it != running_.end() && it->second.command.command_id != c.command_id)
    fx.statuses.push_back(cancel(it, "superseded by " + c.command_id));
  const ServedCapability* s = find(c.instance);
  if (!s) return fx;
  if (auto it = running_.find(c.channel); it != running_.end()) return fx;  // a redelivery of the running one
  Running r{c, s, nullptr, 0, std::nullopt, "pending", std::nullopt};
  if (draining_) {
    fx.statuses.push_back(status(r, CommandState::Refused,
                                 "instance " + c.instance + " is draining (being replaced or stopped)",
                                 c.start_step, 0));
    return fx;
  }
  const auto it = running_.emplace(c.channel, std::move(r)).first;
  // The start step's observation may have come before the command.
  if (auto o = last_obs_.find(c.channel); o != last_obs_.end() && o->second.episode_id == c.episode_id)
    fx.append(step(it, o->second, now));
  return fx;
}

HostEffects HostCore::on_cancel(const CommandCancel& c) {
  HostEffects fx;
  if (!find(c.instance)) return fx;
  auto it = running_.find(c.channel);
  if (it == running_.end() || it->second.command.command_id != c.command_id) return fx;
  fx.statuses.push_back(cancel(it, "cancelled by the governor"));
  return fx;
}

HostEffects HostCore::on_scene_estimate(std::uint32_t channel, const SceneEstimate& e,
                                        Clock::time_point now) {
  // A new episode's world starts from the default limits, until its first command brings the episode's.
  auto [w, fresh] = worlds_.try_emplace(channel, PerceptionLimits{});
  if (!fresh && w->second.episode() != e.episode_id) w->second = PerceivedWorld(PerceptionLimits{});
  w->second.on_estimate(e);
  return retry_awaiting(channel, now);
}

HostEffects HostCore::on_tick(Clock::time_point now) {
  std::vector<std::uint32_t> due;
  for (const auto& [channel, r] : running_)
    if (r.awaiting_frame_since && now - *r.awaiting_frame_since >= r.command.perception.wait) due.push_back(channel);
  HostEffects fx;
  for (const auto channel : due) fx.append(retry_awaiting(channel, now));
  return fx;
}

HostEffects HostCore::on_observation(const Observation& obs, Clock::time_point now) {
  auto& last = last_obs_[obs.channel];
  // A command's start step is said again to every host (SeamEffects::again): a host that had it drops it.
  if (last.episode_id == obs.episode_id && last.step == obs.step && !obs.episode_id.empty()) return {};
  if (last.episode_id != obs.episode_id) keyframes_.erase(obs.channel);
  last = obs;
  take_keyframe(obs);
  auto it = running_.find(obs.channel);
  if (it != running_.end()) return step(it, obs, now);
  // Every observation goes through the channel's perceived world, so it sees each grasp and release.
  if (PerceivedWorld* world = world_for(obs)) {
    Observation seen = obs;
    world->view(seen, {});
  }
  return {};
}

HostEffects HostCore::step(RunningMap::iterator it, const Observation& observed, Clock::time_point now) {
  HostEffects fx;
  Running& r = it->second;
  Observation obs = observed;
  PerceivedWorld* world = world_for(obs);
  const bool same_episode = obs.episode_id == r.command.episode_id;
  const bool perceived = r.command.grounding == Grounding::Perception && same_episode;
  std::optional<Unperceived> unseen;
  if (world) {
    if (perceived) world->set_limits(r.command.perception);
    Observation seen = obs;
    unseen = world->view(seen, perceived ? bound_entities(r.command) : std::vector<std::string>{});
    if (perceived) obs = std::move(seen);
  } else if (perceived) {
    unseen = Unperceived{"no scene estimate from the perception service for this episode", true};
  }
  if (!same_episode || obs.step < r.command.start_step) return fx;
  if (r.last_step && obs.step <= *r.last_step) return fx;  // answered already
  if (perceived && unseen) {
    // A missing or stale frame may still come: wait up to the limit without acting.
    if (unseen->estimate_missing_or_stale) {
      if (!r.awaiting_frame_since) r.awaiting_frame_since = now;
      if (now - *r.awaiting_frame_since < r.command.perception.wait) return fx;
    }
    const std::string why =
        "perception: " + unseen->reason +
        (unseen->estimate_missing_or_stale
             ? "; waited " + std::to_string(r.command.perception.wait.count()) + " ms for a fresh frame"
             : "");
    fx.statuses.push_back(status(r, r.skill ? CommandState::Failed : CommandState::Refused, why, obs.step,
                                 r.steps_used, r.stage, 0,
                                 r.skill ? FailureCode::PerceptionLost : FailureCode::None));
    running_.erase(it);
    return fx;
  }
  r.awaiting_frame_since.reset();
  if (!r.skill && !begin(r, obs, fx)) {
    running_.erase(it);
    return fx;
  }
  r.last_step = obs.step;
  const SkillStep s = r.skill->next(obs);
  if (s.status == SkillStatus::Running && r.steps_used >= r.command.budget_steps) {
    fx.statuses.push_back(
        status(r, CommandState::Expired,
               "command budget of " + std::to_string(r.command.budget_steps) + " steps spent", obs.step,
               r.steps_used, s.stage, s.progress));
    running_.erase(it);
    return fx;
  }
  if (s.status != SkillStatus::Running) {
    const auto st = s.status == SkillStatus::Completed ? CommandState::Completed : CommandState::Failed;
    fx.statuses.push_back(status(r, st, s.reason, obs.step, r.steps_used, s.stage, s.progress,
                                 st == CommandState::Failed ? s.failure : FailureCode::None));
    running_.erase(it);
    return fx;
  }
  fx.actions.push_back({obs.channel, obs.episode_id, r.command.command_id, obs.step, s.action,
                        perceived && world ? world->frames() : 0});
  ++r.steps_used;
  const std::uint32_t period = std::max<std::uint32_t>(1, r.command.decision_period);
  if (s.stage != r.stage || obs.step % period == 0) {
    r.stage = s.stage;
    fx.statuses.push_back(status(r, CommandState::Running, "", obs.step, r.steps_used, s.stage, s.progress));
    fx.statuses.back().planned_steps = static_cast<std::uint32_t>(s.planned_steps);
  }
  return fx;
}

bool HostCore::begin(Running& r, const Observation& obs, HostEffects& fx) {
  std::optional<std::string> why;
  std::unique_ptr<Skill> skill;
  try {
    skill = r.served->def.make(r.command.theta);
  } catch (const std::invalid_argument& e) {
    why = std::string("malformed command: ") + e.what();
  }
  if (!why) why = skill->check(r.command.args, obs, static_cast<int>(r.command.budget_steps));
  if (why) {
    fx.statuses.push_back(status(r, CommandState::Refused, *why, obs.step, 0));
    return false;
  }
  SkillContext ctx;
  if (auto k = keyframes_.find(r.command.channel); k != keyframes_.end()) ctx.keyframes = k->second;
  skill->start(r.command.args, obs, ctx);
  r.skill = std::move(skill);
  fx.statuses.push_back(status(r, CommandState::Accepted, "", obs.step, 0));
  return true;
}

HostEffects HostCore::retry_awaiting(std::uint32_t channel, Clock::time_point now) {
  const auto it = running_.find(channel);
  const auto o = last_obs_.find(channel);
  if (it == running_.end() || !it->second.awaiting_frame_since || o == last_obs_.end()) return {};
  const Observation obs = o->second;
  return step(it, obs, now);
}

// The tool pose when a command starts on a channel with an empty hand: a pose the arm reached safely.
// It is the start step's pose whichever of the command and that step's observation comes first (they
// come on two topics), so the keyframes do not depend on delivery order.
void HostCore::record_keyframe(const CommandStart& c) {
  keyframe_due_[c.channel] = {c.episode_id, c.start_step};
  if (const auto o = last_obs_.find(c.channel); o != last_obs_.end()) take_keyframe(o->second);
}

void HostCore::take_keyframe(const Observation& obs) {
  const auto due = keyframe_due_.find(obs.channel);
  if (due == keyframe_due_.end() || obs.episode_id != due->second.episode_id || obs.step < due->second.step) return;
  const bool at_start = obs.step == due->second.step;
  keyframe_due_.erase(due);
  // A start step whose observation never came leaves no keyframe rather than a later pose.
  if (!at_start || obs.holding()) return;
  auto& k = keyframes_[obs.channel];
  // Commands started on one step (a refused one, then another) leave one keyframe.
  if (k.empty() || k.back().step != obs.step) k.push_back({obs.step, obs.ee_p, obs.ee_q});
}

StatusReport HostCore::status(const Running& r, CommandState st, std::string reason, std::uint32_t step,
                              std::uint32_t used, std::string stage, double progress, FailureCode failure) {
  return {r.command.channel,
          r.command.episode_id,
          r.command.command_id,
          r.command.instance,
          st,
          std::move(reason),
          std::move(stage),
          step,
          used,
          progress,
          failure};
}

}  // namespace dh::cap
