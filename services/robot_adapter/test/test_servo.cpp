// The servoL target of a step: the measured TCP moved by the share of the action's offset that the
// simulator's OSC_POSE spring covers in one step, rotation in the world frame.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "dh/common/robot_contract.hpp"
#include "dh/rtde/servo.hpp"

using namespace dh;

TEST(ServoTarget, AConstantActionMovesTheToolAsFarPerStepAsInTheSimulator) {
  const rtde::UrPose tcp{0.4, -0.1, 0.3, M_PI, 0, 0};  // tool pointing down
  const auto t = rtde::servo_target(tcp, {1, 0, -0.5, 0, 0, 0, 1});
  EXPECT_NEAR(t[0] - tcp[0], robot::kOscStepShare * robot::kMaxDeltaPosM, 1e-12) << "0.0133 m at a = 1";
  EXPECT_NEAR(t[1], tcp[1], 1e-12);
  EXPECT_NEAR(t[2] - tcp[2], -0.5 * robot::kOscStepShare * robot::kMaxDeltaPosM, 1e-12);
  const Eigen::AngleAxisd same(Eigen::Vector3d(t[3], t[4], t[5]).norm(),
                               Eigen::Vector3d(t[3], t[4], t[5]).normalized());
  EXPECT_NEAR(same.angle(), M_PI, 1e-9) << "no rotation asked, none given";
  // A rotation about world z turns a downward tool about the world's z, whatever the tool's own frame.
  const auto turned = rtde::servo_target(tcp, {0, 0, 0, 0, 0, 1, 0});
  const Eigen::Vector3d rv(turned[3], turned[4], turned[5]);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
  const Eigen::Matrix3d want =
      Eigen::AngleAxisd(robot::kOscStepShare * robot::kMaxDeltaRotRad, Eigen::Vector3d::UnitZ())
          .toRotationMatrix() *
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_TRUE(r.isApprox(want, 1e-12)) << r;
  // The zero action holds the measured pose.
  const auto held = rtde::servo_target({0.2, 0.3, 0.4, 0, 0, 0}, {0, 0, 0, 0, 0, 0, -1});
  EXPECT_EQ(held, (rtde::UrPose{0.2, 0.3, 0.4, 0, 0, 0}));
}
