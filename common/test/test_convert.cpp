// The observation crosses the process boundary whole: every field the robot contract puts in it comes back
// from its IDL message as it went in.
#include <gtest/gtest.h>

#include "dh/common/convert.hpp"

using namespace dh;

TEST(Convert, AnObservationSurvivesItsMessage) {
  Observation o;
  o.step = 42;
  o.budget_steps = 300;
  o.ee_p = {-0.3, 0.05, 0.25};
  o.ee_q = {0.1, 0.7, 0.7, 0.1};
  o.gripper_opening = 0.026;
  o.contact_left = true;
  o.gripper = {0.01875, 0.011, 0.008, 0.15};
  o.base_p = {-0.56, 0.02, 0.01};
  o.q = {0.1, -0.2, 0.3, -2.1, 0.4, 2.0, 0.7};
  o.dq = {0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07};
  EntityState e;
  e.name = "wine_bottle";
  e.kind = "cylinder";
  e.p = {-0.36, 0.05, 0.0};
  e.half_extents = {0.035, 0.035, 0.13};
  o.entities = {e};
  o.goal_holds = true;
  const Observation back = convert::from_msg(convert::to_msg(o, 3, "ep-1"));
  EXPECT_EQ(back.channel, 3u);
  EXPECT_EQ(back.episode_id, "ep-1");
  EXPECT_EQ(back.step, o.step);
  EXPECT_EQ(back.budget_steps, o.budget_steps);
  EXPECT_EQ(back.ee_p, o.ee_p);
  EXPECT_EQ(back.ee_q, o.ee_q);
  EXPECT_EQ(back.gripper_opening, o.gripper_opening);
  EXPECT_EQ(back.contact_left, o.contact_left);
  EXPECT_EQ(back.contact_right, o.contact_right);
  EXPECT_EQ(back.gripper, o.gripper);
  EXPECT_EQ(back.base_p, o.base_p);
  EXPECT_EQ(back.q, o.q);
  EXPECT_EQ(back.dq, o.dq);
  ASSERT_EQ(back.entities.size(), 1u);
  EXPECT_EQ(back.entities[0].name, e.name);
  EXPECT_EQ(back.entities[0].p, e.p);
  EXPECT_EQ(back.goal_holds, o.goal_holds);
}
