// Straight-line tool motions with a smooth time profile, tracked under OSC_POSE: the building block every
// analytic skill's stages are made of. A motion is a reference the tool follows, not a pose it is sent to:
// each step's action puts the controller's goal on the reference, led by the reference's next step divided by
// the share of a goal offset the lagging tool covers per step (robot::kOscStepShare), so the tool moves with
// the reference, and whatever error remains pulls it back (docs/controller.md).
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <string>
#include <vector>

#include "dh/common/robot_contract.hpp"

#include "dh/cap/skill.hpp"

namespace dh::cap {

inline constexpr double kGripOpen = -1.0, kGripClose = 1.0;

/// Share of a full action a reference's feed-forward may take at its fastest: the rest corrects the error, so
/// a motion stays trackable when the tool lags or is pushed off. At 0.7 the tool peaks near 0.19 m/s.
inline constexpr double kTrackShare = 0.7;
/// rad/s the tool turns at most: the wrist joints turn it nearly one to one and the controller brakes a joint
/// above 1.8 rad/s (a speed_limited seam event), which the reference's feed-forward would reach at 0.7.
inline constexpr double kMaxTurnRadS = 1.0;
/// The time profile of every motion (0 → 1 over τ = 0 → 1): its speed rises along a half cosine over the
/// first quarter, holds, and falls over the last quarter, so it peaks at 4/3 of its mean (a quintic: 15/8).
double profile(double tau);
/// The fewest steps a motion over `distance` m and `turn` rad needs so the tool can track it.
int track_steps(double distance, double turn);

class Motion {
 public:
  /// A segment from the observed tool pose to (`to`, `q_to`) over `steps` control steps, more when the tool
  /// cannot track it in that many (track_steps).
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
  /// Advances one step: the action that tracks the segment's reference (track), with jaw command `grip`.
  std::array<double, 7> advance(const Observation& obs, double grip);

 private:
  Eigen::Vector3d p_at(int step) const;
  Eigen::Quaterniond q_at(int step) const;

  Eigen::Vector3d from_{0, 0, 0}, to_{0, 0, 0};
  Eigen::Quaterniond q_from_{1, 0, 0, 0}, q_to_{1, 0, 0, 0};
  int steps_ = 1, step_ = 0;
};

/// The action that makes the tool follow a reference at (p, q) now and at (p_next, q_next) a step later: the
/// goal is the reference led by its step over robot::kOscStepShare. Translation and rotation are each scaled
/// down, not clipped per axis, to stay within [-1, 1], so a saturated tool still heads along the reference.
std::array<double, 7> track(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                            const Eigen::Vector3d& p_next, const Eigen::Quaterniond& q_next, double grip);
/// The action that pulls the tool towards a standing reference (p, q): track with no lead.
std::array<double, 7> action_towards(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                                     double grip);

using robot::grip_for_opening;
/// Tool orientation pointing down with the jaw's closing axis (tool y) along the table direction `axis`,
/// of the two such orientations the one nearer the observed tool yaw.
Eigen::Quaterniond jaw_along(const Observation& obs, const Eigen::Vector2d& axis);
/// Direction a fixture's part faces (its -x axis in the world), on the table plane.
Eigen::Vector2d front_of(const EntityState& part);

/// A region or an articulated part (drawer, door, knob): observed at its centre, and nothing a hand carries
/// or pushes.
bool part_or_region(const EntityState& e);
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
