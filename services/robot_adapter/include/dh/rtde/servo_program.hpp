// The URScript program the adapter sends to the controller (primary/secondary interface, TCP 30001/30002)
// and the registers it and the adapter share over RTDE. Our program, written from UR's URScript and RTDE
// documentation (docs/ur-rtde.md); the pattern (a command register polled by a program that servos to a
// pose read from float registers) is the one ur_rtde and UR's own examples use.
//
// Contract: at start, the program echoes the nonce register on its started register; then per controller
// cycle (2 ms):
// - a new target: the sequence register differs from the last one applied and is > 0; the program reads
//   the pose, acknowledges the sequence on its output register and servos to it (servoj on the pose's
//   inverse kinematics, near the measured joints, with ServoTiming's t, lookahead and gain), its joint
//   reference stepping towards that solution no faster than `joint_speed`, so a fast motion near the
//   base, or a large turn of the wrist, does not take the joints past the adapter's envelope;
// - the watchdog: no new target for `watchdog_s`, or sequence 0, and the program stops the arm
//   (stopj with `stop_deceleration`) and waits for the next target. So a dead adapter, a lost link or a
//   seam that holds (an expired lease sends no target) stops the arm on the controller's side;
// - the gripper: the gripper register's value (0 open, 1 closed) on the tool's digital output.
// External RTDE clients may write registers 24–47 only (UR's client library), so the map starts at 24.
#pragma once

#include <array>
#include <string>

#include "dh/rtde/servo.hpp"

namespace dh::rtde {

struct ServoProgram {
  static constexpr const char* kName = "dh_servo";
  static constexpr int kVersion = 2;
  /// Inputs: the target TCP pose (x, y, z m; rotation vector rad; base frame), its sequence, the gripper.
  static constexpr std::array<const char*, 6> kTargetRegisters{
      "input_double_register_24", "input_double_register_25", "input_double_register_26",
      "input_double_register_27", "input_double_register_28", "input_double_register_29"};
  static constexpr const char* kSequenceRegister = "input_int_register_24";
  static constexpr const char* kGripperRegister = "input_int_register_25";
  /// A number the adapter writes before it sends the program, which the program echoes once it runs: a
  /// program of an earlier session still running does not pass for the new one.
  static constexpr const char* kNonceRegister = "input_int_register_26";
  /// Outputs: the sequence the program applied last (0 before the first, or after a watchdog stop), and
  /// the nonce it started with.
  static constexpr const char* kAppliedRegister = "output_int_register_24";
  static constexpr const char* kStartedRegister = "output_int_register_25";

  ServoTiming timing;
  double watchdog_s = 0.1;         ///< two 20 Hz control steps without a target: stop
  double stop_deceleration = 4.0;  ///< rad/s², stopj's
  /// rad/s, each joint's reference at most: 0.75 of the adapter's 2 rad/s envelope, for the arm overshoots
  /// its reference's speed as it catches up (by up to a fifth on the simulated UR7e's wrist)
  double joint_speed = 1.5;
  int gripper_output = 0;          ///< the tool digital output that closes the gripper
};

/// The program's URScript text: one `def dh_servo(): … end` block, which the controller runs when it has
/// received it. Its first line is `def dh_servo():`, its second names the version.
std::string servo_program_text(const ServoProgram& p);

/// Whether `script` is this program, of this version: what a controller that received it runs.
bool is_servo_program(const std::string& script);

}  // namespace dh::rtde
