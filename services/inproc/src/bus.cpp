#include "dh/inproc/bus.hpp"

#include <stdexcept>

namespace dh::inproc {

SeamChannel::SeamChannel(sim::Workcell& cell, std::uint32_t channel, std::string episode_id,
                         std::uint32_t budget_steps)
    : cell_(cell), channel_(channel), episode_(std::move(episode_id)), budget_(budget_steps) {}

Observation SeamChannel::observe() const {
  Observation o = cell_.observe();
  o.channel = channel_;
  o.episode_id = episode_;
  o.step = step_;
  o.budget_steps = budget_;
  return o;
}

std::vector<SeamEvent> SeamChannel::apply(const cap::ActionOut& a, const std::array<double, 7>& applied,
                                          bool& stepped) {
  stepped = false;
  if (a.episode_id != episode_)
    return {{a.step, a.command_id, SeamEventKind::RejectedCommand,
             "action for episode '" + a.episode_id + "' which is not running on this channel"}};
  // The lease reached the seam within the step (one thread), so no grace is waited for.
  const auto r = sim::admit_action(a.command_id, a.step, step_, budget_, lease_, true);
  if (r.decision != sim::Admission::Apply)
    return {{a.step, a.command_id, sim::seam_event_kind(r.decision), r.reason}};
  std::vector<SeamEvent> events;
  for (const auto& e : cell_.step(applied))
    events.push_back({step_, a.command_id, sim::seam_event_kind(e.kind), e.reason});
  ++step_;
  stepped = true;
  return events;
}

CommandRunner::CommandRunner(sim::Workcell& cell, cap::HostCore& host, std::uint32_t budget_steps)
    : cell_(cell), host_(host), episode_budget_(budget_steps) {}

void CommandRunner::begin_episode(const std::string& episode_id) {
  seam_.emplace(cell_, 0, episode_id, episode_budget_);
  host_.on_observation(seam_->observe(), step_time(0));
}

CommandOutcome CommandRunner::run(const std::string& capability, const cap::Bindings& args,
                                  const cap::Theta& theta, std::uint32_t budget_steps) {
  if (!seam_) throw std::logic_error("CommandRunner::run before begin_episode");
  const cap::ServedCapability* served = host_.serving(capability);
  if (!served) throw std::invalid_argument("the host core serves no capability '" + capability + "'");
  cap::CommandStart c;
  c.episode_id = seam_->episode_id();
  c.command_id = seam_->episode_id() + "/c" + std::to_string(commands_++);
  c.capability = capability;
  c.instance = served->instance;
  c.args = args;
  c.theta = theta;
  c.start_step = seam_->step();
  c.budget_steps = budget_steps;
  seam_->on_lease(
      {true, c.command_id, c.start_step + budget_steps, c.start_step + budget_steps, false, false});

  CommandOutcome out;
  Observation obs = seam_->observe();
  out.last = obs;
  cap::HostEffects fx = host_.on_start(c, step_time(obs.step));
  for (;;) {
    for (const auto& s : fx.statuses) {
      if (!ended(s.state)) continue;
      out.state = s.state;
      out.failure = s.failure;
      out.reason = s.reason;
      out.stage = s.stage;
      out.steps = s.steps_used;
      return out;
    }
    if (fx.actions.empty())
      throw std::logic_error("command " + c.command_id + " neither acted nor ended at step " +
                             std::to_string(obs.step));
    const cap::ActionOut& a = fx.actions.back();
    bool stepped = false;
    for (const auto& e : seam_->apply(a, a.a, stepped))
      out.safety_events += e.kind == SeamEventKind::SafetyHold;
    if (!stepped)
      throw std::logic_error("the seam refused the action of " + c.command_id + " at step " +
                             std::to_string(a.step));
    obs = seam_->observe();
    out.last = obs;
    out.goal |= obs.goal_holds;
    fx = host_.on_observation(obs, step_time(obs.step));
  }
}

}  // namespace dh::inproc
