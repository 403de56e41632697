#include "dh/rtde/servo.hpp"

#include <Eigen/Geometry>

#include "dh/common/robot_contract.hpp"

namespace dh::rtde {

namespace {

Eigen::AngleAxisd angle_axis(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, rotation_vector / angle)
                   : Eigen::AngleAxisd(0, Eigen::Vector3d::UnitZ());
}

}  // namespace

UrPose servo_target(const UrPose& tcp, const std::array<double, 7>& a) {
  const double share = robot::kOscStepShare;
  const Eigen::Vector3d dp = share * robot::kMaxDeltaPosM * Eigen::Vector3d(a[0], a[1], a[2]);
  const Eigen::Vector3d dr = share * robot::kMaxDeltaRotRad * Eigen::Vector3d(a[3], a[4], a[5]);
  // World-frame rotation: the increment is applied on the left of the measured orientation.
  const Eigen::Matrix3d r =
      angle_axis(dr).toRotationMatrix() * angle_axis({tcp[3], tcp[4], tcp[5]}).toRotationMatrix();
  const Eigen::AngleAxisd out(r);
  const Eigen::Vector3d rv = out.angle() * out.axis();
  return {tcp[0] + dp.x(), tcp[1] + dp.y(), tcp[2] + dp.z(), rv.x(), rv.y(), rv.z()};
}

}  // namespace dh::rtde
