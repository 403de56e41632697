// UR poses carry orientation as a rotation vector (axis × angle, rad); these convert it to and from a
// rotation matrix, for the servo target, the arm's cell and the simulated controller alike.
#pragma once

#include <Eigen/Geometry>

namespace dh::rtde {

inline Eigen::Matrix3d rotation_of(const Eigen::Vector3d& rv) {
  const double angle = rv.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, rv / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

inline Eigen::Vector3d rotation_vector_of(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

}  // namespace dh::rtde
