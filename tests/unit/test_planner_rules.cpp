#include <gtest/gtest.h>

#include "dh/planner/rules.hpp"

using namespace dh::planner;

namespace {
PlanContext ctx(const std::string& instruction) {
  return {instruction, {"bowl", "plate", "cream_cheese", "wine_bottle"}, {"pick_place"}, {}};
}
}  // namespace

TEST(Rules, PutTheBowlOnThePlate) {
  const auto a = plan_rules(ctx("put the bowl on the plate"));
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  EXPECT_EQ(a.args, (std::vector<std::pair<std::string, std::string>>{{"object", "bowl"}, {"target", "plate"}}));
}

TEST(Rules, NounPhrasesResolveToEntityNames) {
  const auto a = plan_rules(ctx("Put the black bowl on top of the plate."));
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.args[0].second, "bowl");
  EXPECT_EQ(resolve_entity("the cream cheese", {"cream_cheese", "bowl"}), "cream_cheese");
  EXPECT_EQ(resolve_entity("the mug", {"cream_cheese", "bowl"}), "");
}

TEST(Rules, WhatCannotBeFormedIsARefusalWithItsReason) {
  auto a = plan_rules(ctx("put the mug on the plate"));
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("the mug'"), std::string::npos) << a.reason;
  a = plan_rules(ctx("dance"));
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("does not understand"), std::string::npos);
  a = plan_rules(ctx(""));
  EXPECT_TRUE(a.refused);
  PlanContext none = ctx("put the bowl on the plate");
  none.capabilities.clear();
  a = plan_rules(none);
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("no eligible capability"), std::string::npos);
}
