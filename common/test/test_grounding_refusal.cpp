// Grounding's refusal codes read back as written, and the slow brain's own are told from execution's.
#include <gtest/gtest.h>

#include "dh/common/grounding_refusal.hpp"

using dh::Refusal;

TEST(GroundingRefusal, EveryCodeReadsBackAsWritten) {
  for (int i = 0; i <= static_cast<int>(Refusal::Perception); ++i) {
    const auto r = static_cast<Refusal>(i);
    EXPECT_EQ(dh::refusal_from_string(dh::to_string(r)), r) << dh::to_string(r);
  }
  EXPECT_FALSE(dh::refusal_from_string("planner"));
  EXPECT_FALSE(dh::refusal_from_string(""));
}

TEST(GroundingRefusal, OnlyThePlannersOwnAreThePlanners) {
  EXPECT_TRUE(dh::is_planner(Refusal::PlannerRefused));
  EXPECT_TRUE(dh::is_planner(Refusal::PlannerUnavailable));
  EXPECT_TRUE(dh::is_planner(Refusal::PlannerMalformed));
  for (Refusal r : {Refusal::UnknownCapability, Refusal::CapabilityNotAlive, Refusal::CapabilityMasked,
                    Refusal::MissingArgument, Refusal::UnresolvedEntity, Refusal::Precondition,
                    Refusal::Budget, Refusal::Perception})
    EXPECT_FALSE(dh::is_planner(r)) << dh::to_string(r);
}
