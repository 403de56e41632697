#include "dh/sim/osc_pose.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>

namespace dh::sim {

namespace {
using Mat7 = Eigen::Matrix<double, 7, 7>;
using Vec7 = Eigen::Matrix<double, 7, 1>;

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

OscPose::OscPose(const mjModel_* m, std::array<int, 7> dofs, std::array<int, 7> qpos, int site,
                 std::array<double, 7> q_null, std::array<double, 7> effort, OscGains gains)
    : m_(m), dof_(dofs), qpos_(qpos), site_(site), g_(gains) {
  for (int i = 0; i < 7; ++i) {
    q_null_[i] = q_null[i];
    effort_[i] = effort[i];
  }
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
  const int nv = m_->nv;
  // The arm's block of the joint-space mass matrix, read from MuJoCo's sparse qM (row i holds M(i, i),
  // then M(i, parent), up the dof tree: mj_fullM's layout) without forming the nv x nv matrix.
  Mat7 M = Mat7::Zero();
  for (int k = 0; k < 7; ++k) {
    int adr = m_->dof_Madr[dof_[k]];
    for (int j = dof_[k]; j >= 0; j = m_->dof_parentid[j], ++adr)
      for (int l = 0; l < 7; ++l)
        if (dof_[l] == j) M(k, l) = M(l, k) = d->qM[adr];
  }
  mj_jacSite(m_, d, jacp_.data(), jacr_.data(), site_);
  Eigen::Matrix<double, 6, 7> J;
  Vec7 q, dq;
  for (int i = 0; i < 7; ++i) {
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

  const Mat7 M_inv = M.llt().solve(Mat7::Identity());
  const Eigen::Matrix<double, 6, 6> lambda_inv = J * M_inv * J.transpose();
  const Eigen::Matrix3d lambda_pos = pinv_psd<3>(lambda_inv.topLeftCorner<3, 3>());
  const Eigen::Matrix3d lambda_ori = pinv_psd<3>(lambda_inv.bottomRightCorner<3, 3>());
  const Eigen::Matrix<double, 6, 6> lambda = pinv_psd<6>(lambda_inv);
  Eigen::Matrix<double, 6, 1> wrench;
  wrench << lambda_pos * f, lambda_ori * t;

  // Null space of the task (dynamically consistent): a joint-space pull towards the ready pose.
  const double null_kv = 2 * std::sqrt(g_.null_kp);
  const Eigen::Matrix<double, 7, 6> J_bar = M_inv * J.transpose() * lambda;
  const Mat7 N = Mat7::Identity() - J_bar * J;
  const Vec7 null_torque = N.transpose() * (M * (g_.null_kp * (q_null_ - q) - null_kv * dq));

  Vec7 u = J.transpose() * wrench + null_torque;
  bool limited = false;
  const double dt = m_->opt.timestep;
  for (int i = 0; i < 7; ++i) {
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
