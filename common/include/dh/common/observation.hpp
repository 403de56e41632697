// What the robot seam observes at one control step, as plain data for logic libraries (no DDS).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "dh/common/robot_contract.hpp"

namespace dh {

struct EntityState {
  std::string name, kind;
  /// Bottom centre (m) of an object or fixture; a region's centre; an articulated part's grip centre.
  std::array<double, 3> p{};
  std::array<double, 4> q{1, 0, 0, 0};     ///< w, x, y, z
  std::array<double, 3> half_extents{};    ///< m
  double joint = 0;  ///< an articulated part's joint position (m or rad); 0 for other entities
  // What a person calls it and how it relates to the rest: the slow brain reads an instruction against
  // these, not against the entity's name.
  std::string category;  ///< "bowl", "cream cheese", "drawer", "knob"; empty for a region
  std::string colour;    ///< "black", "yellow and white"; empty when the scene does not say
  std::string owner;     ///< a part's fixture; a region's entity or part ("cabinet_top_drawer")
  std::string relation;  ///< a region's relation to its owner: in, on, front_of, back_of, left_of, right_of
};

struct Observation {
  std::uint32_t channel = 0;  ///< the simulator (or cell) channel it came from
  std::uint32_t step = 0;
  std::uint32_t budget_steps = 0;
  std::array<double, 3> ee_p{};
  std::array<double, 4> ee_q{1, 0, 0, 0};
  double gripper_opening = 0;
  bool contact_left = false, contact_right = false;
  robot::Gripper gripper;  ///< the jaw's shape, as the arm's robot profile declares it
  std::array<double, 3> base_p{};  ///< where the arm's base stands (world, m): what a skill judges reach from
  std::array<double, 7> q{}, dq{};
  std::vector<EntityState> entities;
  bool goal_holds = false;  ///< the benchmark predicate at this step
  std::string episode_id;   ///< the episode the step belongs to (with `step`, what cores order by)

  /// The jaw holds something: both fingers touch and the jaw is not shut on itself.
  bool holding() const { return contact_left && contact_right && gripper_opening > robot::kJawShutM; }
  /// `o` is what the jaw holds: holding, with `o` at the tool (within its half size and 1 cm) and below it.
  bool in_jaw(const EntityState& o) const {
    return holding() && std::hypot(ee_p[0] - o.p[0], ee_p[1] - o.p[1]) < std::max(o.half_extents[0], o.half_extents[1]) + 0.01 &&
           ee_p[2] > o.p[2];
  }

  const EntityState* entity(const std::string& name) const {
    for (const auto& e : entities)
      if (e.name == name) return &e;
    return nullptr;
  }
};

}  // namespace dh
