#include <gtest/gtest.h>

#include "dh/sim/seam.hpp"

using dh::sim::Admission;
using dh::sim::admit_action;
using dh::sim::LeaseState;

namespace {
LeaseState lease(std::uint32_t valid, std::uint32_t budget) {
  LeaseState l;
  l.known = true;
  l.command_id = "c0";
  l.valid_until_step = valid;
  l.budget_until_step = budget;
  return l;
}
}  // namespace

TEST(Seam, AppliesAnActionInsideLeaseAndBudgets) {
  EXPECT_EQ(admit_action("c0", 5, 5, 300, lease(10, 200), false).decision, Admission::Apply);
}

TEST(Seam, RejectsAStaleOrFutureStep) {
  const auto r = admit_action("c0", 4, 5, 300, lease(10, 200), false);
  EXPECT_EQ(r.decision, Admission::RejectStep);
  EXPECT_NE(r.reason.find("channel is at step 5"), std::string::npos);
}

TEST(Seam, RejectsWhenTheEpisodeBudgetIsSpent) {
  const auto r = admit_action("c0", 300, 300, 300, lease(310, 400), false);
  EXPECT_EQ(r.decision, Admission::RejectBudget);
  EXPECT_NE(r.reason.find("episode budget of 300"), std::string::npos);
}

TEST(Seam, RejectsWhenTheCommandBudgetIsSpent) {
  const auto r = admit_action("c0", 200, 200, 300, lease(210, 200), false);
  EXPECT_EQ(r.decision, Admission::RejectBudget);
  EXPECT_NE(r.reason.find("command budget"), std::string::npos);
}

TEST(Seam, HoldsAnActionPastItsLeaseHoweverLongItWaits) {
  for (const bool grace_elapsed : {false, true}) {
    const auto r = admit_action("c0", 10, 10, 300, lease(10, 200), grace_elapsed);
    EXPECT_EQ(r.decision, Admission::WaitForLease);
    EXPECT_NE(r.reason.find("expired at step 10"), std::string::npos);
  }
}

TEST(Seam, RejectsARevokedLeaseAtOnce) {
  LeaseState l = lease(20, 200);
  l.revoked = true;
  EXPECT_EQ(admit_action("c0", 12, 12, 300, l, false).decision, Admission::RejectLease);
}

TEST(Seam, HoldsAStepValidActionWhileTheLeaseWriterIsSilent) {
  LeaseState l = lease(20, 200);
  l.writer_silent = true;
  for (const bool grace_elapsed : {false, true})
    EXPECT_EQ(admit_action("c0", 12, 12, 300, l, grace_elapsed).decision, Admission::WaitForLease);
  l.revoked = true;  // a revocation still refuses
  EXPECT_EQ(admit_action("c0", 12, 12, 300, l, false).decision, Admission::RejectLease);
}

TEST(Seam, AnUnknownCommandWaitsThenIsRejected) {
  EXPECT_EQ(admit_action("other", 3, 3, 300, lease(10, 200), false).decision, Admission::WaitForLease);
  EXPECT_EQ(admit_action("other", 3, 3, 300, lease(10, 200), true).decision, Admission::RejectCommand);
  EXPECT_EQ(admit_action("c0", 3, 3, 300, LeaseState{}, true).decision, Admission::RejectCommand);
}
