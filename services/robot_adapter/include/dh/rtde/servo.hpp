// What a 20 Hz action means to a UR arm's servoL (issue 19 asks it declared). The action keeps the robot
// contract's meaning (common/include/dh/common/robot_contract.hpp): Δposition × 0.05 m and Δrotation ×
// 0.5 rad (axis-angle, world frame) from the *measured* tool pose, then the gripper. In simulation
// robosuite's OSC_POSE spring covers kOscStepShare (26.55 %) of that offset in one 50 ms step, and the
// next step's goal is rebased on the measured pose again; so the servoL target of a step is the measured
// TCP pose moved by that share of the offset, which the arm then reaches within the step: a constant
// action moves the tool as far per step on the metal as in the simulator (0.0133 m × a). The controller
// servos to it every cycle with servoL's timing below (ur_rtde's defaults, docs/ur-rtde.md); the program
// runs servoL as ur_rtde does, servoj on the pose's inverse kinematics (servo_program.hpp).
#pragma once

#include <array>

namespace dh::rtde {

/// servoL's arguments besides the pose.
struct ServoTiming {
  double t_s = 0.002;        ///< the controller's period at 500 Hz
  double lookahead_s = 0.1;  ///< UR allows 0.03–0.2 s
  double gain = 300;         ///< UR allows 100–2000
};

/// A UR pose: x, y, z (m) and a rotation vector (rad), base frame.
using UrPose = std::array<double, 6>;

/// The servoL target for `action` (robot contract, 7-d; a[6] the gripper, not used here) from the
/// measured TCP pose.
UrPose servo_target(const UrPose& measured_tcp, const std::array<double, 7>& action);

}  // namespace dh::rtde
