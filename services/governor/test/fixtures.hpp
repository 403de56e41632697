// Shared test fixtures: a scene observation and a registry with pick_place announced.
#pragma once

#include "dh/common/observation.hpp"
#include "dh/gov/registry.hpp"

namespace dh::test {

/// An object named and of kind `name`, upright, at `p` (its bottom centre).
inline EntityState entity(const std::string& name, std::array<double, 3> p, std::array<double, 3> half_extents,
                          std::array<double, 4> q = {1, 0, 0, 0}) {
  EntityState e;
  e.name = e.kind = name;
  e.p = p;
  e.q = q;
  e.half_extents = half_extents;
  return e;
}

inline Observation scene_observation(std::uint32_t step = 0) {
  Observation o;
  o.step = step;
  o.budget_steps = 300;
  o.ee_p = {-0.1, 0, 0.25};
  o.ee_q = {0, 1, 0, 0};
  o.gripper_opening = 0.08;
  o.entities = {entity("bowl", {0, -0.15, 0}, {0.065, 0.065, 0.025}), entity("plate", {0, 0.15, 0}, {0.09, 0.09, 0.006})};
  return o;
}

inline gov::CapabilityInfo pick_place_info(const std::string& instance = "pick_place@a", std::uint64_t started = 1) {
  gov::CapabilityInfo i;
  i.capability = "pick_place";
  i.instance = instance;
  i.version = "0.1.0";
  i.arguments = {"object", "target"};
  i.preconditions = {"distinct_entities", "gripper_empty", "task_goal_unmet"};
  i.parameters = {{"corridor_height", 0.16}};
  i.cost_steps = 221;
  i.started_ns = started;
  return i;
}

inline gov::CapabilityInfo vla_act_info(const std::string& instance = "vla_act@a") {
  gov::CapabilityInfo i;
  i.capability = "vla_act";
  i.instance = instance;
  i.version = "0.1.0";
  i.arguments = {"instruction:*"};
  i.preconditions = {"task_goal_unmet"};
  i.cost_steps = 100;
  i.started_ns = 1;
  return i;
}

}  // namespace dh::test
