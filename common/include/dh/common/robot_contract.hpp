// The robot contract: what an action and an observation mean, in one place for the seam (simulator or
// hardware adapter) and every skill. An action is 7-d, robosuite's OSC_POSE as LIBERO configures it: the
// controller's goal is the measured tool pose moved by Δposition and Δrotation (axis-angle, world frame),
// scaled below at |a| = 1, tracked by a critically damped spring; then the gripper command.
// docs/controller.md gives the sources.
#pragma once

#include <algorithm>
#include <cstdint>

namespace dh::robot {

inline constexpr double kControlPeriodS = 0.05;        ///< one control step: actions and observations at 20 Hz
inline constexpr std::uint32_t kDecisionPeriodSteps = 10;  ///< default steps between decisions (2 Hz); an
                                                          ///< episode's arm may set another, its commands carry it
inline constexpr double kMaxDeltaPosM = 0.05;   ///< tool translation per step at |a| = 1 (OSC_POSE output_max)
inline constexpr double kMaxDeltaRotRad = 0.5;  ///< tool rotation per step at |a| = 1

/// The controller's operational-space stiffness (1/s², per unit of task-space mass) and damping, critically
/// damped: kd = 2 ζ √kp with ζ = 1.
inline constexpr double kOscKp = 150;
inline constexpr double kOscKd = 24.494897427831781;
static_assert(kOscKd * kOscKd > 4 * kOscKp - 1e-9 && kOscKd * kOscKd < 4 * kOscKp + 1e-9);

/// The controller's lag, as a skill steering the tool must know it. The goal is rebased on the
/// measured pose every step, so the tool never reaches it: a constant action settles at a speed
/// where the tool covers this share of the goal's offset per step. It is the spring's exact
/// one-step response over T = 50 ms, with x = √kp T: α + βγ / (1 − δ), where
/// α = 1 − (1 + x) e^−x is the share of the offset covered from rest, β = T e^−x the distance a
/// unit speed carries, γ = kp T e^−x the speed the offset gives and δ = (1 − x) e^−x the speed kept
/// (docs/controller.md). A skill's feed-forward divides a reference's step by it: 0.05 m × a
/// moves the tool 0.0133 m × a a step, 0.265 m/s × a (not 1 m/s); for rotation, 2.65 rad/s × a.
inline constexpr double kOscStepShare = 0.2655;

/// The gripper command a[6]: -1 opens the jaw fully, +1 closes it; in between, a finger gap.
inline constexpr double kJawMaxGapM = 0.08;  ///< finger gap at a[6] = -1 (each finger travels half of it)
inline double finger_target(double command) { return kJawMaxGapM / 2 * (1.0 - command) / 2.0; }
/// The command that holds the fingers `gap` m apart.
inline double grip_for_opening(double gap) { return std::clamp(1.0 - gap / (kJawMaxGapM / 2), -1.0, 1.0); }

/// Below this observed opening the jaw is shut on itself: whatever it closed on, it holds nothing.
inline constexpr double kJawShutM = 0.002;

/// The jaw's shape about the tool centre point, as a skill plans contact with it: what differs between
/// grippers behind the same action. Each robot profile declares its own (configs/robots/*.yaml, checked
/// against its model), and the seam puts it in every observation. The defaults are the Panda's hand.
struct Gripper {
  double pad_below_tcp = 0.01;    ///< m the finger pads reach below the tool centre point, along the tool axis
  double pad_half_width = 0.01;   ///< m half a pad's width, across the closing direction
  double pad_thickness = 0.014;   ///< m a pad's thickness, along the closing direction
  double hand_above_tcp = 0.101;  ///< m the hand's body reaches above the tool centre point
  bool operator==(const Gripper&) const = default;
};

}  // namespace dh::robot
