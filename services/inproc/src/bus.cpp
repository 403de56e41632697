#include "dh/inproc/bus.hpp"

#include <stdexcept>

#include "dh/gov/grounding.hpp"

namespace dh::inproc {

CommandRunner::CommandRunner(sim::Workcell& cell, cap::HostCore& host, std::uint32_t budget_steps)
    : cell_(cell), host_(host), episode_budget_(budget_steps) {}

void CommandRunner::begin_episode(const std::string& episode_id) {
  host_.on_observation(*seam_.start(cell_, episode_id, episode_budget_, "", step_time(0)).observation, step_time(0));
}

void CommandRunner::resume_episode(const std::string& episode_id, const std::string& predicate,
                                   const sim::StateRecord& from) {
  const auto now = step_time(from.step);
  host_.on_observation(*seam_.resume(cell_, episode_id, episode_budget_, predicate, from, now).observation, now);
}

CommandOutcome CommandRunner::run(const std::string& capability, const cap::Bindings& args,
                                  const cap::Theta& theta, std::uint32_t budget_steps) {
  const cap::ServedCapability* served = host_.serving(capability);
  if (!served) throw std::invalid_argument("the host core serves no capability '" + capability + "'");
  cap::CommandStart c;
  c.episode_id = seam_.episode_id();
  c.command_id = seam_.episode_id() + "/c" + std::to_string(commands_++);
  c.capability = capability;
  c.instance = served->instance;
  c.args = args;
  c.theta = theta;
  c.budget_steps = budget_steps;
  return run(std::move(c));
}

CommandOutcome CommandRunner::run(cap::CommandStart c) {
  if (!seam_.running()) throw std::logic_error("CommandRunner::run before begin_episode or resume_episode");
  c.start_step = seam_.step();
  // The governor's lease without its decisions: valid through the budget, raised as the governor raises it
  // for a plan longer than the cost model (gov::raised_budget).
  std::uint32_t budget_steps = c.budget_steps;
  const std::uint32_t remaining = episode_budget_ > c.start_step ? episode_budget_ - c.start_step : 0;
  const auto lease = [&](std::uint32_t now_step) {
    const std::uint32_t until = c.start_step + budget_steps;
    seam_.on_lease({seam_.episode_id(), c.command_id, until, until, false}, step_time(now_step));
    host_.on_lease(c.channel, seam_.episode_id(), c.command_id, until);
  };
  lease(c.start_step);  // the host learns of the command only at its start, below

  CommandOutcome out;
  Observation obs = seam_.observation();
  out.last = obs;
  cap::HostEffects fx = host_.on_start(c, step_time(obs.step));
  for (;;) {
    for (const auto& s : fx.statuses) {
      if (!ended(s.state)) {
        if (const auto b = gov::raised_budget(budget_steps, s.planned_steps, remaining); b != budget_steps) {
          budget_steps = b;
          lease(s.step);
        }
        continue;
      }
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
    const sim::SeamEffects sx =
        seam_.on_action({a.episode_id, a.command_id, a.step, a.a, a.frames}, step_time(a.step));
    for (const auto& e : sx.events) {
      out.safety_events += e.kind == SeamEventKind::SafetyHold;
      out.speed_limited += e.kind == SeamEventKind::SpeedLimited;
    }
    if (!sx.observation)
      throw std::logic_error("the seam did not apply the action of " + c.command_id + " at step " +
                             std::to_string(a.step) + (sx.ended ? ": " + *sx.ended : std::string()));
    obs = *sx.observation;
    out.last = obs;
    if (after_step) after_step(obs.step);
    out.goal |= obs.goal_holds;
    fx = host_.on_observation(obs, step_time(obs.step));
  }
}

}  // namespace dh::inproc
