// The arm controller the benchmark was measured with before robosuite's OSC_POSE (osc_pose.hpp): each
// control step a damped-least-squares IK turns the pose goal into joint goals, reached by speed-capped
// joint references under a joint PD with bias compensation. An action's goal is met within the step
// (the tool moves 0.05 m at |a| = 1), which the skills were tuned to until they tracked OSC's lag. A scene
// picks it with `robot: controller: joint_ik`; the default is osc_pose.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <vector>

struct mjModel_;
struct mjData_;

namespace dh::sim {

/// Joint PD with bias (gravity, Coriolis) compensation towards `q_ref` at speed `dq_ref`, clipped to
/// `effort`: what JointIk tracks with, and what holds the arm still during a safety hold. The first
/// `joints` entries of each array are the arm's (6 or 7).
void joint_pd(const mjData_* d, const std::array<int, 7>& dofs, const std::array<int, 7>& qpos,
              const std::array<double, 7>& q_ref, const std::array<double, 7>& dq_ref,
              const std::array<double, 7>& effort, std::array<double, 7>& tau, std::size_t joints = 7);

class JointIk {
 public:
  JointIk(const mjModel_* m, std::array<int, 7> dofs, std::array<int, 7> qpos, int site, std::array<double, 7> q_ready,
          std::array<double, 7> lower, std::array<double, 7> upper, std::array<double, 7> effort, double speed_limit);
  ~JointIk();
  JointIk(const JointIk&) = delete;
  JointIk& operator=(const JointIk&) = delete;

  /// Once per control step: the joint goals reaching position `p_goal` and orientation `q_goal`.
  void set_goal(const mjData_* d, const Eigen::Vector3d& p_goal, const Eigen::Quaterniond& q_goal, double period);
  /// At substep time `t` (s since the step began), after mj_step1: the clipped arm torques.
  void torques(const mjData_* d, double t, std::array<double, 7>& tau) const;

 private:
  const mjModel_* m_;
  mjData_* ik_;
  std::array<int, 7> dof_, qpos_;
  int site_;
  std::array<double, 7> q_ready_, lower_, upper_, effort_;
  double speed_limit_;
  std::array<double, 7> q0_{}, q_goal_{}, v_ref_{};
  std::vector<double> jacp_, jacr_;
};

}  // namespace dh::sim
