#include "dh/sim/joint_ik.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cstring>

#include "dh/common/geometry.hpp"

namespace dh::sim {

namespace {
// Joint-space PD gains of the tracking controller (per arm joint, base to tip).
constexpr std::array<double, 7> kKp{900, 900, 700, 700, 300, 200, 100};
constexpr std::array<double, 7> kKd{80, 80, 60, 60, 20, 15, 8};
constexpr double kIkDamping = 0.05;
constexpr double kNullGain = 0.1;
}  // namespace

void joint_pd(const mjData_* d, const std::array<int, 7>& dofs, const std::array<int, 7>& qpos,
              const std::array<double, 7>& q_ref, const std::array<double, 7>& dq_ref,
              const std::array<double, 7>& effort, std::array<double, 7>& tau, std::size_t joints) {
  for (std::size_t i = 0; i < joints; ++i)
    tau[i] = std::clamp(kKp[i] * (q_ref[i] - d->qpos[qpos[i]]) + kKd[i] * (dq_ref[i] - d->qvel[dofs[i]]) +
                            d->qfrc_bias[dofs[i]],
                        -effort[i], effort[i]);
}

JointIk::JointIk(const mjModel_* m, std::array<int, 7> dofs, std::array<int, 7> qpos, int site,
                 std::array<double, 7> q_ready, std::array<double, 7> lower, std::array<double, 7> upper,
                 std::array<double, 7> effort, double speed_limit)
    : m_(m), ik_(mj_makeData(m)), dof_(dofs), qpos_(qpos), site_(site), q_ready_(q_ready), lower_(lower),
      upper_(upper), effort_(effort), speed_limit_(speed_limit) {
  jacp_.resize(3 * static_cast<std::size_t>(m->nv));
  jacr_.resize(3 * static_cast<std::size_t>(m->nv));
}

JointIk::~JointIk() { mj_deleteData(ik_); }

void JointIk::set_goal(const mjData_* d, const Eigen::Vector3d& p_goal, const Eigen::Quaterniond& q_goal,
                       double period) {
  std::memcpy(ik_->qpos, d->qpos, sizeof(mjtNum) * m_->nq);
  Eigen::Matrix<double, 7, 1> q_ready;
  for (int i = 0; i < 7; ++i) q_ready[i] = q_ready_[i];
  Eigen::Matrix<double, 6, 7> J;
  for (int iter = 0; iter < 4; ++iter) {
    mj_kinematics(m_, ik_);
    mj_comPos(m_, ik_);
    std::array<double, 4> q_now{};
    mju_mat2Quat(q_now.data(), ik_->site_xmat + 9 * site_);
    Eigen::Matrix<double, 6, 1> err;
    err.head<3>() = p_goal - Eigen::Map<const Eigen::Vector3d>(ik_->site_xpos + 3 * site_);
    err.tail<3>() = geo::rotvec_between(geo::quat(q_now), q_goal);
    mj_jacSite(m_, ik_, jacp_.data(), jacr_.data(), site_);  // row-major 3 x nv
    for (int i = 0; i < 7; ++i)
      for (int k = 0; k < 3; ++k) {
        J(k, i) = jacp_[k * m_->nv + dof_[i]];
        J(3 + k, i) = jacr_[k * m_->nv + dof_[i]];
      }
    const Eigen::Matrix<double, 6, 6> JJt =
        J * J.transpose() + kIkDamping * kIkDamping * Eigen::Matrix<double, 6, 6>::Identity();
    const Eigen::Matrix<double, 7, 6> Jpinv = J.transpose() * JJt.inverse();
    Eigen::Matrix<double, 7, 1> q;
    for (int i = 0; i < 7; ++i) q[i] = ik_->qpos[qpos_[i]];
    const Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Identity() - Jpinv * J;
    const Eigen::Matrix<double, 7, 1> step = Jpinv * err + N * (kNullGain * (q_ready - q));
    for (int i = 0; i < 7; ++i) ik_->qpos[qpos_[i]] = std::clamp(q[i] + step[i], lower_[i] + 0.01, upper_[i] - 0.01);
  }
  for (int i = 0; i < 7; ++i) {
    q_goal_[i] = ik_->qpos[qpos_[i]];
    q0_[i] = d->qpos[qpos_[i]];
    v_ref_[i] = std::clamp((q_goal_[i] - q0_[i]) / period, -speed_limit_, speed_limit_);
  }
}

void JointIk::torques(const mjData_* d, double t, std::array<double, 7>& tau) const {
  std::array<double, 7> q_ref{}, dq_ref{};
  for (int i = 0; i < 7; ++i) {
    q_ref[i] = q0_[i] + v_ref_[i] * t;
    dq_ref[i] = v_ref_[i];
    if ((v_ref_[i] > 0 && q_ref[i] > q_goal_[i]) || (v_ref_[i] < 0 && q_ref[i] < q_goal_[i])) {
      q_ref[i] = q_goal_[i];
      dq_ref[i] = 0;
    }
  }
  joint_pd(d, dof_, qpos_, q_ref, dq_ref, effort_, tau);
}

}  // namespace dh::sim
