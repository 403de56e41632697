// Runs pick_place against a MuJoCo workcell in one process (no DDS): the physics and the skill
// exactly as the services run them, for fast tests of grasping and placement.
#pragma once

#include <cstdint>
#include <string>

#include "dh/cap/pick_place.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::test {

struct InProcessOutcome {
  bool success = false;          ///< the goal predicate held at some step
  int steps = 0;                 ///< steps until the skill ended
  int first_success_step = -1;
  cap::SkillStatus status = cap::SkillStatus::Running;
  std::string reason, stage;
  int safety_events = 0;
};

inline InProcessOutcome run_pick_place(sim::Workcell& cell, const TaskDef& task, std::uint64_t seed,
                                       const std::string& object, const std::string& target) {
  cell.reset(seed, task.goal);
  cap::PickPlaceSkill skill{cap::PickPlaceParams{}};
  Observation obs = cell.observe();
  obs.budget_steps = task.budget_steps;
  InProcessOutcome out;
  if (auto refusal = skill.check(object, target, obs, static_cast<int>(task.budget_steps))) {
    out.status = cap::SkillStatus::Failed;
    out.reason = "refused: " + *refusal;
    return out;
  }
  skill.start(object, target, obs);
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
    if (obs.goal_holds && out.first_success_step < 0) out.first_success_step = out.steps;
  }
  out.success = out.first_success_step >= 0;
  return out;
}

}  // namespace dh::test
