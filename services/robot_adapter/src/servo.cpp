#include "dh/rtde/servo.hpp"

#include "dh/common/robot_contract.hpp"
#include "rotation_vector.hpp"

namespace dh::rtde {

UrPose servo_target(const UrPose& tcp, const std::array<double, 7>& a) {
  const double share = robot::kOscStepShare;
  const Eigen::Vector3d dp = share * robot::kMaxDeltaPosM * Eigen::Vector3d(a[0], a[1], a[2]);
  const Eigen::Vector3d dr = share * robot::kMaxDeltaRotRad * Eigen::Vector3d(a[3], a[4], a[5]);
  // World-frame rotation: the increment is applied on the left of the measured orientation.
  const Eigen::Vector3d rv = rotation_vector_of(rotation_of(dr) * rotation_of({tcp[3], tcp[4], tcp[5]}));
  return {tcp[0] + dp.x(), tcp[1] + dp.y(), tcp[2] + dp.z(), rv.x(), rv.y(), rv.z()};
}

}  // namespace dh::rtde
