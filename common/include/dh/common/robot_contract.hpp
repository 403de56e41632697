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

/// The gripper command a[6]: -1 opens the jaw fully, +1 closes it; in between, a finger gap.
inline constexpr double kJawMaxGapM = 0.08;  ///< finger gap at a[6] = -1 (each finger travels half of it)
inline double finger_target(double command) { return kJawMaxGapM / 2 * (1.0 - command) / 2.0; }
/// The command that holds the fingers `gap` m apart.
inline double grip_for_opening(double gap) { return std::clamp(1.0 - gap / (kJawMaxGapM / 2), -1.0, 1.0); }

/// Below this observed opening the jaw is shut on itself: whatever it closed on, it holds nothing.
inline constexpr double kJawShutM = 0.002;

}  // namespace dh::robot
