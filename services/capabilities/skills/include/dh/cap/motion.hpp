// Straight-line tool motions with a smooth time profile, turned into OSC_POSE-like actions: the
// building block every analytic skill's stages are made of.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <string>
#include <vector>

#include "dh/common/robot_contract.hpp"

#include "dh/cap/skill.hpp"

namespace dh::cap {

inline constexpr double kGripOpen = -1.0, kGripClose = 1.0;
inline constexpr double kMaxJaw = 0.08;  ///< m, full opening of the parallel jaw

class Motion {
 public:
  /// A segment from the observed tool pose to (`to`, `q_to`) over `steps` control steps.
  void go(const Observation& obs, const Eigen::Vector3d& to, const Eigen::Quaterniond& q_to, int steps);
  /// Stay where the tool is for `steps` steps (closing or opening the jaw).
  void hold(const Observation& obs, int steps);
  bool done() const { return step_ >= steps_; }
  int steps() const { return steps_; }
  int elapsed() const { return step_; }
  const Eigen::Vector3d& from() const { return from_; }
  const Eigen::Vector3d& to() const { return to_; }
  /// Distance from the tool to the segment's end.
  double error(const Observation& obs) const;
  /// Advances one step; the action moves the tool towards this step's waypoint with jaw command `grip`.
  std::array<double, 7> advance(const Observation& obs, double grip);

 private:
  Eigen::Vector3d from_{0, 0, 0}, to_{0, 0, 0};
  Eigen::Quaterniond q_from_{1, 0, 0, 0}, q_to_{1, 0, 0, 0};
  int steps_ = 1, step_ = 0;
};

/// The action that moves the tool from the observed pose towards (p, q) at once, clamped to [-1, 1].
std::array<double, 7> action_towards(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                                     double grip);

using robot::grip_for_opening;
/// Tool orientation pointing down with the jaw's closing axis (tool y) along the table direction `axis`,
/// of the two such orientations the one nearer the observed tool yaw.
Eigen::Quaterniond jaw_along(const Observation& obs, const Eigen::Vector2d& axis);
/// Direction a fixture's part faces (its -x axis in the world), on the table plane.
Eigen::Vector2d front_of(const EntityState& part);

/// Height of an entity's top surface: an object or fixture from its bottom, a region from its centre.
double top_of(const EntityState& e);
/// The height to come down from onto `at`: at least `at`'s own, and `clearance` above the top of every
/// entity (not region, not `except`) whose footprint lies within `reach` of the vertical through it.
double clear_height(const Observation& obs, const Eigen::Vector3d& at, double reach, double clearance,
                    const std::string& except);
/// The lowest height (at least `floor`) a tool path from `from` to `to` on the table plane may run at to
/// pass `clearance` above every entity (regions included: an open drawer's inside stands above its
/// walls' level) whose footprint it passes within `reach` of, except those named in `skip`.
double path_height(const Observation& obs, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double reach,
                   double clearance, double floor, const std::vector<std::string>& skip);

}  // namespace dh::cap
