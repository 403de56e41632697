#include <gtest/gtest.h>

#include "dh/sim/safety.hpp"

using namespace dh::sim;

TEST(Safety, JointSpeedsInsideTheEnvelopePass) {
  SafetyLimits l;
  EXPECT_TRUE(check_joint_speeds({1.9, -1.9, 0, 0, 0, 0, 2.0}, l).ok);
}

TEST(Safety, TheFirstJointOverTheEnvelopeIsNamed) {
  SafetyLimits l;
  const auto v = check_joint_speeds({0, 0, -2.05, 3.0, 0, 0, 0}, l);
  EXPECT_FALSE(v.ok);
  EXPECT_EQ(v.joint, 2);
  EXPECT_DOUBLE_EQ(v.speed, 2.05);
  EXPECT_NE(v.reason.find("joint 3"), std::string::npos);
}

TEST(Safety, WorkspaceClampReportsAndClamps) {
  SafetyLimits l;
  l.workspace_min = {-0.4, -0.4, 0.0};
  l.workspace_max = {0.4, 0.4, 0.5};
  std::array<double, 3> inside{0.1, 0.2, 0.3};
  EXPECT_FALSE(clamp_to_workspace(inside, l));
  std::array<double, 3> outside{0.9, -0.5, -0.1};
  EXPECT_TRUE(clamp_to_workspace(outside, l));
  EXPECT_DOUBLE_EQ(outside[0], 0.4);
  EXPECT_DOUBLE_EQ(outside[1], -0.4);
  EXPECT_DOUBLE_EQ(outside[2], 0.0);
}
