// Runs one skill against a MuJoCo workcell in one process (no DDS): the physics and the skill exactly as
// the services run them, for fast tests of grasping, pushing and moving parts.
#pragma once

#include <cstdint>
#include <string>

#include "dh/cap/skill.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::test {

struct SkillOutcome {
  bool goal = false;             ///< the task's goal held at some step
  int steps = 0;                 ///< steps until the skill ended
  cap::SkillStatus status = cap::SkillStatus::Running;
  std::string reason, stage;
  int safety_events = 0;
  Observation last;
};

/// Resets `cell` to `task` and `seed` (unless `reset` is false), then runs `skill` with `args`.
inline SkillOutcome run_skill(sim::Workcell& cell, const TaskDef& task, std::uint64_t seed, cap::Skill& skill,
                              const cap::Bindings& args, bool reset = true, cap::SkillContext ctx = {}) {
  if (reset) cell.reset(seed, task.goal);
  Observation obs = cell.observe();
  obs.budget_steps = task.budget_steps;
  SkillOutcome out;
  if (auto refusal = skill.check(args, obs, static_cast<int>(task.budget_steps))) {
    out.status = cap::SkillStatus::Failed;
    out.reason = "refused: " + *refusal;
    out.last = obs;
    return out;
  }
  skill.start(args, obs, ctx);
  for (unsigned t = 0; t < task.budget_steps; ++t) {
    obs.step = t;
    const cap::SkillStep s = skill.next(obs);
    out.stage = s.stage;
    if (s.status != cap::SkillStatus::Running) {
      out.status = s.status;
      out.reason = s.reason;
      break;
    }
    for (const auto& e : cell.step(s.action))
      if (e.kind == sim::StepEvent::SafetyHold) ++out.safety_events;
    obs = cell.observe();
    obs.budget_steps = task.budget_steps;
    out.steps = static_cast<int>(t) + 1;
    out.goal |= obs.goal_holds;
  }
  out.last = obs;
  return out;
}

}  // namespace dh::test
