// Pose helpers on Eigen: quaternions stored w, x, y, z as in MuJoCo and the IDL.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace dh::geo {

inline Eigen::Quaterniond quat(const std::array<double, 4>& q) { return {q[0], q[1], q[2], q[3]}; }
inline std::array<double, 4> wxyz(const Eigen::Quaterniond& q) { return {q.w(), q.x(), q.y(), q.z()}; }
inline Eigen::Vector3d vec(const std::array<double, 3>& v) { return {v[0], v[1], v[2]}; }

/// Rotation vector (axis × angle, world frame) taking `from` to `to`.
inline Eigen::Vector3d rotvec_between(const Eigen::Quaterniond& from, const Eigen::Quaterniond& to) {
  Eigen::Quaterniond d = to * from.conjugate();
  if (d.w() < 0) d.coeffs() *= -1;
  Eigen::AngleAxisd aa(d.normalized());
  return aa.axis() * aa.angle();
}

/// Wraps an angle to (-π, π].
inline double wrap(double a) {
  while (a > std::numbers::pi) a -= 2 * std::numbers::pi;
  while (a <= -std::numbers::pi) a += 2 * std::numbers::pi;
  return a;
}

/// Tool pointing straight down (tool z = -world z), rotated by `yaw` about world z.
inline Eigen::Quaterniond top_down(double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())) *
         Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()));
}

/// Yaw of a tool's x axis projected onto the table plane.
inline double tool_yaw(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

/// Smooth 0→1 profile (quintic, zero velocity and acceleration at both ends).
inline double smooth(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * s * (10 - 15 * s + 6 * s * s);
}

}  // namespace dh::geo
