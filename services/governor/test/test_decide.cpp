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
  s.recoveries_left = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::InsertRecovery);
  s.recoveries_left = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan) << "one recovery per step";
  s.replans_used = 4;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}

TEST(Decide, AFailureGetsARecoveryThenARetry) {
  DecisionState s = running();
  s.phase = CommandPhase::Failed;
  s.failures_of_step = 1;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.recovery_available = s.recoveries_left = true;
  const Decision d = decide(s, {});
  EXPECT_EQ(d.kind, DecisionKind::InsertRecovery);
  EXPECT_NE(d.reason.find("retry 1 of 1"), std::string::npos) << d.reason;
}

TEST(Decide, SpentRetriesGoToASubstituteThenThePolicyThenThePlanner) {
  DecisionState s = running();
  s.phase = CommandPhase::Failed;
  s.failures_of_step = 2;
  s.recovery_available = s.recoveries_left = true;  // recoveries serve retries only
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
  s.vla_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::HandToVla);
  s.substitute_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Substitute);
  s.replans_used = 4;
  s.substitute_available = s.vla_available = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}

TEST(Decide, ARefusalIsNotRetriedButSubstituted) {
  // A capability that refused before moving would refuse again: the push of Figure 3 becomes a pick and place.
  DecisionState s = running();
  s.phase = CommandPhase::Refused;
  s.failures_of_step = 1;
  s.recovery_available = s.recoveries_left = true;
  s.substitute_available = true;
  const Decision d = decide(s, {});
  EXPECT_EQ(d.kind, DecisionKind::Substitute);
  EXPECT_NE(d.reason.find("substitute"), std::string::npos);
  s.substitute_available = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
}

TEST(Decide, ARefusedStepNoCapabilityTakesGoesBackToThePlannerBeforeThePolicy) {
  // The planner named a basket for the pick: the pick and the push both refuse it at their checks. A new plan
  // costs no control step; vla_act would spend its budget on the same infeasible step.
  DecisionState s = running();
  s.phase = CommandPhase::Refused;
  s.failures_of_step = 1;
  s.vla_available = true;
  const Decision d = decide(s, {});
  EXPECT_EQ(d.kind, DecisionKind::RequestReplan);
  EXPECT_NE(d.reason.find("planner"), std::string::npos) << d.reason;
  s.failures_of_step = 2;  // the planner advised the refused step again
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::HandToVla);
  s.failures_of_step = 1;
  s.replans_used = 4;  // no replan left: the policy is what remains
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::HandToVla);
  s.replans_used = 0;
  s.phase = CommandPhase::Failed;  // a step that moved and failed twice still goes to the policy
  s.failures_of_step = 2;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::HandToVla);
}

TEST(Decide, StaticModeRetriesThenReexecutesThePlanNeverSubstitutes) {
  DecisionState s = running();
  s.mode = ExecutorMode::Static;
  s.phase = CommandPhase::Refused;
  s.failures_of_step = 1;
  s.substitute_available = s.recovery_available = s.recoveries_left = s.vla_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry) << "fixed retries, refusals included";
  s.failures_of_step = 2;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
  s.phase = CommandPhase::Running;
  s.stagnant_decisions = 8;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan) << "no recovery insertion in static";
}

TEST(Decide, SeqModeRunsItsFrozenPlanInOrder) {
  DecisionState s = running();
  s.mode = ExecutorMode::Seq;
  s.phase = CommandPhase::Completed;
  s.sequence_left = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::NextInSequence);
  s.sequence_left = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
  s.phase = CommandPhase::Failed;
  s.failures_of_step = 1;
  s.substitute_available = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.failures_of_step = 2;
  s.sequence_left = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::NextInSequence);
  s.sequence_left = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}

TEST(Decide, ALostInstanceIsRetriedOnlyWhenAnotherLives) {
  DecisionState s = running();
  s.phase = CommandPhase::Lost;
  s.failures_of_step = 2;
  s.other_instance_alive = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.other_instance_alive = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
}

TEST(Decide, ACompletedCommandWithoutVerdictAsksForTheNextStep) {
  DecisionState s = running();
  s.phase = CommandPhase::Completed;
  s.replans_used = 4;  // next-step requests do not spend replans
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::RequestReplan);
}

TEST(Decide, AnEndedRecoveryResumesTheInterruptedStep) {
  DecisionState s = running();
  s.was_recovery = true;
  for (auto phase : {CommandPhase::Completed, CommandPhase::Failed, CommandPhase::Refused}) {
    s.phase = phase;
    EXPECT_EQ(decide(s, {}).kind, DecisionKind::Resume) << to_string(phase);
  }
}

TEST(Decide, WithoutTheLatchAHeldVerdictDoesNotEndTheEpisode) {
  DecisionState s = running();
  s.latched = true;
  s.latch_enabled = false;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Continue);
}

TEST(Decide, BarePolicyRunsUntilLatchOrBudgetAndGetsTheRestAfterAnEarlyEnd) {
  DecisionState s = running();
  s.mode = ExecutorMode::Bare;
  s.stagnant_decisions = 100;  // a policy is never judged by progress
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Continue);
  s.phase = CommandPhase::Failed;
  s.failures_of_step = 1;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.failures_of_step = 2;  // a policy that keeps failing (its server is down) is not retried for ever
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
  s.phase = CommandPhase::Lost;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
  s.other_instance_alive = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::Retry);
  s.phase = CommandPhase::Refused;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
  s.phase = CommandPhase::Running;
  s.latched = true;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::StopSuccess);
  s.latched = false;
  s.step = s.budget_steps;
  EXPECT_EQ(decide(s, {}).kind, DecisionKind::GiveUp);
}
