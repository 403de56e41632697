// The seam's safety envelope, checked at 50 Hz inside every control step: joint speeds within the
// command's velocity envelope (2 rad/s, the paper's Appendix A) and targets inside the workspace box.
#pragma once

#include <array>
#include <optional>
#include <string>

namespace dh::sim {

struct SafetyLimits {
  double joint_speed = 2.0;  ///< rad/s, every arm joint
  std::array<double, 3> workspace_min{-1, -1, -1};
  std::array<double, 3> workspace_max{1, 1, 1};
};

struct SafetyVerdict {
  bool ok = true;
  int joint = -1;  ///< first joint over the envelope
  double speed = 0;
  std::string reason;
};

/// Checks |dq_i| <= limit for the arm joints (a 6-joint arm leaves the seventh at 0).
SafetyVerdict check_joint_speeds(const std::array<double, 7>& dq, const SafetyLimits& limits);

/// Makes an action one the robot contract allows: every component finite (NaN and infinities become 0) and
/// within [-1, 1]. Returns why, naming the first component it changed; nullopt when it changed none.
std::optional<std::string> clamp_action(std::array<double, 7>& a);

/// Clamps a position target into the workspace box; returns true when it had to.
bool clamp_to_workspace(std::array<double, 3>& p, const SafetyLimits& limits);

}  // namespace dh::sim
