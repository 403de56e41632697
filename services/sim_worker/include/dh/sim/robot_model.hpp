// The arm, read once from its URDF (configs/robots/): joint limits for the safety envelope, and the
// MuJoCo model made from the same file, so the URDF is the one source of truth.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dh::sim {

struct JointLimits {
  std::string name;
  double lower = 0, upper = 0;  ///< rad (m for prismatic)
  double velocity = 0;          ///< rad/s
  double effort = 0;            ///< N·m (N)
};

struct RobotSpec {
  std::filesystem::path urdf;
  std::string urdf_xml;              ///< the file's text, read once
  std::string name;
  std::vector<JointLimits> arm;      ///< the 6 or 7 revolute joints, base to tip
  std::vector<JointLimits> fingers;  ///< prismatic finger joints (the first drives, the rest mimic)
  std::string tcp_link = "tcp";
};

/// Reads the URDF with urdfdom; throws ConfigError naming the file when it cannot be parsed or does
/// not have 6 or 7 revolute joints, prismatic fingers and a `tcp` link.
RobotSpec load_robot(const std::filesystem::path& urdf);

struct MjcfFragments {
  std::string body;        ///< <body> tree rooted at the base link
  std::string actuators;   ///< <motor> per arm joint (ctrlrange = effort), <position> for the gripper
  std::string equalities;  ///< finger mimic couplings
};

/// MJCF elements for the robot placed at `base_pos`. Every link's collision geometry collides with the
/// scene; arm links do not collide with each other or with the gripper (robot_model.cpp says how).
/// `finger_friction` is the sliding friction of the finger pads. The hand carries the camera "wrist"
/// (camera.hpp).
MjcfFragments robot_mjcf(const RobotSpec& spec, const double base_pos[3], double finger_friction);

}  // namespace dh::sim
