#include "dh/sim/osc_pose.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace dh::sim {

namespace {

/// Pseudo-inverse of a symmetric positive semi-definite matrix: directions it cannot move get no force.
template <int N>
Eigen::Matrix<double, N, N> pinv_psd(const Eigen::Matrix<double, N, N>& a) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> es(a);
  Eigen::Matrix<double, N, 1> inv = es.eigenvalues();
  const double cutoff = 1e-9 * std::max(1.0, inv.cwiseAbs().maxCoeff());
  for (int i = 0; i < N; ++i) inv[i] = inv[i] > cutoff ? 1.0 / inv[i] : 0.0;
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}
}  // namespace

OscPose::OscPose(const mjModel_* m, std::size_t joints, std::array<int, 7> dofs, std::array<int, 7> qpos, int site,
                 std::array<double, 7> q_null, std::array<double, 7> effort, OscGains gains)
    : m_(m), n_(joints), dof_(dofs), qpos_(qpos), site_(site), q_null_(q_null), effort_(effort), g_(gains) {
  if (n_ != 6 && n_ != 7)
    throw std::invalid_argument("the operational-space controller drives 6 or 7 arm joints, not " + std::to_string(n_));
  jacp_.resize(3 * static_cast<std::size_t>(m->nv));
  jacr_.resize(3 * static_cast<std::size_t>(m->nv));
}

void OscPose::set_goal(const mjData_* d, const Eigen::Vector3d& dp, const Eigen::Vector3d& dr) {
  p_goal_ = Eigen::Map<const Eigen::Vector3d>(d->site_xpos + 3 * site_) + dp;
  // robosuite compares each rotation component with 0 exactly (math.isclose with its default tolerances).
  if (dr.x() != 0 || dr.y() != 0 || dr.z() != 0) {
    const Eigen::Matrix3d r = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->site_xmat + 9 * site_);
    r_goal_ = Eigen::AngleAxisd(dr.norm(), dr.normalized()).toRotationMatrix() * r;
  }
}

bool OscPose::torques(const mjData_* d, std::array<double, 7>& tau) {
  return n_ == 7 ? law<7>(d, tau) : law<6>(d, tau);
}

template <int N>
bool OscPose::law(const mjData_* d, std::array<double, 7>& tau) {
  using MatN = Eigen::Matrix<double, N, N>;
  using VecN = Eigen::Matrix<double, N, 1>;
  const int nv = m_->nv;
  // The arm's block of the joint-space mass matrix, read from MuJoCo's sparse qM (row i holds M(i, i),
  // then M(i, parent), up the dof tree: mj_fullM's layout) without forming the nv x nv matrix.
  MatN M = MatN::Zero();
  for (int k = 0; k < N; ++k) {
    int adr = m_->dof_Madr[dof_[k]];
    for (int j = dof_[k]; j >= 0; j = m_->dof_parentid[j], ++adr)
      for (int l = 0; l < N; ++l)
        if (dof_[l] == j) M(k, l) = M(l, k) = d->qM[adr];
  }
  mj_jacSite(m_, d, jacp_.data(), jacr_.data(), site_);
  Eigen::Matrix<double, 6, N> J;
  VecN q, dq;
  for (int i = 0; i < N; ++i) {
    for (int r = 0; r < 3; ++r) {
      J(r, i) = jacp_[r * nv + dof_[i]];
      J(3 + r, i) = jacr_[r * nv + dof_[i]];
    }
    q[i] = d->qpos[qpos_[i]];
    dq[i] = d->qvel[dof_[i]];
  }
  const Eigen::Matrix<double, 6, 1> twist = J * dq;
  const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(d->site_xpos + 3 * site_);
  const Eigen::Matrix3d r = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->site_xmat + 9 * site_);
  Eigen::Vector3d e_o = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c) e_o += 0.5 * r.col(c).cross(r_goal_.col(c));

  const Eigen::Vector3d f = g_.kp * (p_goal_ - p) - g_.kd * twist.head<3>();
  const Eigen::Vector3d t = g_.kp * e_o - g_.kd * twist.tail<3>();

  const MatN M_inv = M.llt().solve(MatN::Identity());
  const Eigen::Matrix<double, 6, 6> lambda_inv = J * M_inv * J.transpose();
  const Eigen::Matrix3d lambda_pos = pinv_psd<3>(lambda_inv.topLeftCorner<3, 3>());
  const Eigen::Matrix3d lambda_ori = pinv_psd<3>(lambda_inv.bottomRightCorner<3, 3>());
  const Eigen::Matrix<double, 6, 6> lambda = pinv_psd<6>(lambda_inv);
  Eigen::Matrix<double, 6, 1> wrench;
  wrench << lambda_pos * f, lambda_ori * t;

  // Null space of the task (dynamically consistent): a joint-space pull towards the ready pose.
  const double null_kv = 2 * std::sqrt(g_.null_kp);
  const Eigen::Matrix<double, N, 6> J_bar = M_inv * J.transpose() * lambda;
  const MatN null_space = MatN::Identity() - J_bar * J;
  const VecN q_null = Eigen::Map<const VecN>(q_null_.data());
  const VecN null_torque = null_space.transpose() * (M * (g_.null_kp * (q_null - q) - null_kv * dq));

  VecN u = J.transpose() * wrench + null_torque;
  bool limited = false;
  const double dt = m_->opt.timestep;
  for (int i = 0; i < N; ++i) {
    double torque = u[i];
    const double over = std::abs(dq[i]) - g_.speed_limit;
    // Brake an over-fast joint back to the limit within a few substeps.
    if (over > 0) {
      torque = -std::copysign(M(i, i) * over / (4 * dt), dq[i]);
      limited = true;
    }
    tau[i] = std::clamp(torque + d->qfrc_bias[dof_[i]], -effort_[i], effort_[i]);
  }
  return limited;
}

}  // namespace dh::sim
