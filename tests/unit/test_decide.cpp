#include <gtest/gtest.h>

#include "dh/gov/decide.hpp"

using namespace dh::gov;

TEST(Latch, StaysFalseUntilAnEventThenStaysTrue) {
  VerdictLatch l;
  EXPECT_FALSE(l.decide(10));
  l.record(13, true);
  l.record(14, false);  // the predicate flickers off: the event is retained
  EXPECT_FALSE(l.decide(10)) << "an event after the decision step is not read early";
  EXPECT_TRUE(l.decide(20));
  EXPECT_EQ(l.event_step(), 13u);
  l.record(21, false);
  EXPECT_TRUE(l.decide(30));
}

TEST(Latch, FalseEventsNeverLatch) {
  VerdictLatch l;
  for (std::uint32_t t = 0; t < 100; ++t) l.record(t, false);
  EXPECT_FALSE(l.decide(100));
}

namespace {
DecisionState running() {
  DecisionState s;
  s.phase = CommandPhase::Running;
  s.step = 50;
  s.budget_steps = 300;
  s.progress = 0.2;
  return s;
}
}  // namespace

TEST(Decide, LatchedVerdictStopsWithSuccessBeforeAnythingElse) {
  DecisionState s = running();
  s.latched = true;
  s.step = 300;  // even at budget exhaustion
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::StopSuccess);
}

TEST(Decide, BudgetExhaustionGivesUp) {
  DecisionState s = running();
  s.step = 300;
  const Decision d = decide(s, {});
  EXPECT_EQ(d.kind, DecisionKind::GiveUp);
  EXPECT_NE(d.reason.find("budget"), std::string::npos);
}

TEST(Decide, ARunningCommandContinuesUntilItStagnates) {
  DecisionState s = running();
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Continue);
  s.stagnant_decisions = 8;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
  s.recovery_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::InsertRecovery);
}

TEST(Decide, AFailureIsRetriedThenRoutedElsewhere) {
  DecisionState s = running();
  s.phase = CommandPhase::Failed;
  s.failures_of_capability = 1;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.failures_of_capability = 2;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
  s.vla_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::HandToVla);
  s.recovery_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::InsertRecovery);
  s.substitute_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Substitute);
  s.replans_used = 4;
  s.substitute_available = s.recovery_available = s.vla_available = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}

TEST(Decide, StaticModeNeverSubstitutesOrHandsToThePolicy) {
  DecisionState s = running();
  s.mode = ExecutorMode::Static;
  s.phase = CommandPhase::Failed;
  s.failures_of_capability = 2;
  s.substitute_available = s.recovery_available = s.vla_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
  s.mode = ExecutorMode::Seq;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}

TEST(Decide, ALostInstanceIsRetriedOnlyWhenAnotherLives) {
  DecisionState s = running();
  s.phase = CommandPhase::Lost;
  s.failures_of_capability = 1;
  s.other_instance_alive = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.other_instance_alive = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
}

TEST(Decide, ACompletedCommandWithoutVerdictAsksThePlanner) {
  DecisionState s = running();
  s.phase = CommandPhase::Completed;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
}
