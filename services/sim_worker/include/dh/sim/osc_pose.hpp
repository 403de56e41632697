// The arm controller behind the seam: robosuite's OSC_POSE as LIBERO configures it (osc_pose.json, robosuite
// 1.4): once per control step the goal becomes the measured tool pose plus the scaled action; at every
// physics substep an operational-space law (kp 150, critically damped, position and orientation decoupled)
// pulls the tool to it, gravity and Coriolis compensated, with a null-space pull (kp 10) towards the ready
// pose. Behind it sits a joint-speed limiter that brakes any arm joint above its limit and counts the
// substeps it did so. docs/controller.md gives the sources and what differs from robosuite.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <vector>

#include "dh/common/robot_contract.hpp"

struct mjModel_;
struct mjData_;

namespace dh::sim {

struct OscGains {
  double kp = robot::kOscKp;   ///< per unit of the operational-space mass: osc_pose.json
  double kd = robot::kOscKd;   ///< 2 ζ √kp, ζ = 1
  double null_kp = 10;         ///< robosuite's fixed null-space stiffness (nullspace_torques)
  double speed_limit = 1.8;    ///< rad/s: the limiter's threshold, below the seam's 2 rad/s envelope
};

class OscPose {
 public:
  /// `dofs` and `qpos` are the arm joints' addresses (6 or 7 of them, base to tip; the rest of each array
  /// unused), `site` the tool site, `q_null` the pose the null space is pulled towards and `effort` each
  /// motor's torque limit. Throws std::invalid_argument for another joint count.
  OscPose(const mjModel_* m, std::size_t joints, std::array<int, 7> dofs, std::array<int, 7> qpos, int site,
          std::array<double, 7> q_null, std::array<double, 7> effort, OscGains gains = {});

  /// Once per control step: the position goal is the measured tool position plus `dp` (m, world frame);
  /// the orientation goal turns by the axis-angle `dr` (rad, world frame) from the measured orientation,
  /// and stays what it was when `dr` is exactly zero, as robosuite's does.
  void set_goal(const mjData_* d, const Eigen::Vector3d& dp, const Eigen::Vector3d& dr);
  /// The orientation goal as it is now: the seam keeps it in the physics state (mjData's userdata), since
  /// it outlives the control step.
  Eigen::Quaterniond orientation_goal() const { return Eigen::Quaterniond(r_goal_); }
  void set_orientation_goal(const Eigen::Quaterniond& q) { r_goal_ = q.normalized().toRotationMatrix(); }
  const Eigen::Vector3d& position_goal() const { return p_goal_; }

  /// At every substep, after mj_step1 (which leaves the mass matrix, Jacobians and bias forces current):
  /// the arm torques (the first `joints` of `tau`), clipped to each motor's limit. Returns whether the
  /// speed limiter braked a joint.
  bool torques(const mjData_* d, std::array<double, 7>& tau);

 private:
  /// The law for an arm of N joints: fixed-size matrices, so the 7-joint arithmetic is what it always was.
  template <int N>
  bool law(const mjData_* d, std::array<double, 7>& tau);

  const mjModel_* m_;
  std::size_t n_;
  std::array<int, 7> dof_, qpos_;
  int site_;
  std::array<double, 7> q_null_, effort_;
  OscGains g_;
  Eigen::Vector3d p_goal_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d r_goal_ = Eigen::Matrix3d::Identity();
  std::vector<double> jacp_, jacr_;  ///< 3 x nv, sized once
};

}  // namespace dh::sim
