#include <gtest/gtest.h>

#include "dh/gov/episode.hpp"
#include "dh/gov/grounding.hpp"
#include "machine_fixture.hpp"

using namespace dh;
using namespace dh::gov;
using namespace std::chrono_literals;

using Machine = test::MachineTest;

namespace {
bool nothing(const Effects& fx) {
  return !fx.plan_request && !fx.command && !fx.lease && !fx.cancel_command && !fx.end;
}
}  // namespace

TEST_F(Machine, PlansGroundsDispatchesRenewsAndEndsOnTheLatchedVerdict) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  ASSERT_TRUE(fx.plan_request);
  EXPECT_EQ(fx.plan_request->capabilities, std::vector<std::string>{"pick_place"});
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  ASSERT_TRUE(fx.lease);
  EXPECT_EQ(fx.lease->valid_until_step, 10u);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  for (std::uint32_t t = 1; t < 10; ++t) EXPECT_FALSE(m->on_observation(test::scene_observation(t), t0).lease);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Running, "", "lift", 10, 10, 0.1}, t0);
  fx = m->on_observation(test::scene_observation(10), t0);
  ASSERT_TRUE(fx.lease) << "a decision step renews the lease";
  EXPECT_EQ(fx.lease->valid_until_step, 20u);
  Observation done = test::scene_observation(165);
  done.goal_holds = true;
  EXPECT_FALSE(m->on_observation(done, t0).end) << "the latch is read at the next decision";
  fx = m->on_observation(test::scene_observation(170), t0);
  ASSERT_TRUE(fx.end);
  EXPECT_TRUE(fx.end->success);
  EXPECT_EQ(fx.end->steps, 170u);
  EXPECT_EQ(fx.cancel_command, "ep/c0");
  ASSERT_TRUE(fx.lease);
  EXPECT_TRUE(fx.lease->revoked);
  const auto k = kinds();
  for (const char* want : {"episode_start", "plan_request", "advice", "grounding", "dispatch", "command_status",
                           "decision", "episode_end"})
    EXPECT_NE(std::find(k.begin(), k.end(), want), k.end()) << want;
}

// An episode long enough that the cost model's budget is not capped by it.
struct LongMachine : test::MachineTest {
  void configure_spec(EpisodeSpec& s) override { s.budget_steps = 1000; }
};

TEST_F(LongMachine, APlanLongerThanTheCostModelRaisesTheBudgetAtOnceWithinTheEpisode) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  const std::uint32_t budget = fx.command->budget_steps;  // of the announced cost
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  for (std::uint32_t t = 1; t <= 5; ++t) m->on_observation(test::scene_observation(t), t0);
  // A plan that fits the budget's cost changes nothing; a status that says nothing of its plan neither.
  fx = m->on_status({"ep/c0", "pick_place@a", CommandState::Running, "", "approach", 5, 5, 0.1,
                     FailureCode::None, (budget - 10) * 2 / 3},
                    t0);
  EXPECT_TRUE(nothing(fx));
  fx = m->on_status({"ep/c0", "pick_place@a", CommandState::Running, "", "approach", 5, 5, 0.1}, t0);
  EXPECT_TRUE(nothing(fx));
  // A longer plan: the budget its length would have had, at once (the capability spends meanwhile), on a
  // lease still valid to a decision period past the step seen.
  fx = m->on_status(
      {"ep/c0", "pick_place@a", CommandState::Running, "", "descent", 5, 5, 0.1, FailureCode::None, budget},
      t0);
  ASSERT_TRUE(fx.lease);
  EXPECT_EQ(fx.lease->command_id, "ep/c0");
  EXPECT_EQ(fx.lease->budget_until_step, command_budget(budget, 1000));
  EXPECT_GT(fx.lease->budget_until_step, budget);
  EXPECT_EQ(fx.lease->valid_until_step, 15u);
  EXPECT_FALSE(fx.lease->revoked);
  // Never more than the episode had left when the command started, and never less than it has.
  fx = m->on_status(
      {"ep/c0", "pick_place@a", CommandState::Running, "", "carry", 6, 6, 0.1, FailureCode::None, 5000}, t0);
  ASSERT_TRUE(fx.lease);
  EXPECT_EQ(fx.lease->budget_until_step, 1000u);
  fx = m->on_status(
      {"ep/c0", "pick_place@a", CommandState::Running, "", "lower", 7, 7, 0.2, FailureCode::None, budget},
      t0);
  EXPECT_TRUE(nothing(fx));
  // The next decision's lease keeps the raised budget, and the evidence says when and why it was raised.
  for (std::uint32_t t = 6; t < 10; ++t) m->on_observation(test::scene_observation(t), t0);
  fx = m->on_observation(test::scene_observation(10), t0);
  ASSERT_TRUE(fx.lease);
  EXPECT_EQ(fx.lease->budget_until_step, 1000u);
  const auto k = kinds();
  EXPECT_EQ(std::count(k.begin(), k.end(), "budget_raised"), 2);
}

TEST_F(Machine, RefusalsAreRecordedAndEndTheEpisodeAfterTheLimit) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  for (int i = 0; i < config.max_refusals; ++i) {
    ASSERT_TRUE(fx.plan_request) << i;
    Advice a = good(fx.plan_request->request_id);
    a.capability = "fly";
    fx = m->on_advice(a, t0);
  }
  ASSERT_TRUE(fx.end);
  EXPECT_FALSE(fx.end->success);
  EXPECT_EQ(fx.end->outcome, Outcome::GaveUp);
  EXPECT_EQ(fx.end->refusals, static_cast<std::uint32_t>(config.max_refusals));
  const auto recs = read_evidence(file);
  const auto n = std::count_if(recs.begin(), recs.end(), [](const auto& r) {
    return r["kind"] == "refusal" && r["refusal"] == "unknown_capability";
  });
  EXPECT_EQ(n, config.max_refusals);
}

TEST_F(Machine, ALostCapabilityEndsTheCommandWithoutAHang) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  m->on_observation(test::scene_observation(7), t0);
  registry.set_alive("pick_place@a", false);
  fx = m->on_capability_lost("pick_place@a", t0);
  EXPECT_EQ(fx.cancel_command, "ep/c0");
  ASSERT_TRUE(fx.lease);
  EXPECT_TRUE(fx.lease->revoked) << "the lost command's lease is revoked at the seam";
  ASSERT_TRUE(fx.plan_request) << "no other instance: the planner is asked again";
  EXPECT_TRUE(fx.plan_request->capabilities.empty());
}

TEST_F(Machine, AMissingAcknowledgementAndASilentPlannerHitTheirDeadlines) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_tick(t0 + config.planner_timeout + 1ms);
  ASSERT_TRUE(fx.plan_request) << "planner timeout counts as a refusal and asks again";
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  fx = m->on_tick(t0 + config.ack_timeout + 1ms);
  ASSERT_TRUE(fx.command) << "no acknowledgement: retried";
  EXPECT_EQ(fx.command->command_id, "ep/c1");
}

TEST_F(Machine, NoFirstObservationIsAnInfrastructureFailure) {
  const Effects fx = m->on_tick(t0 + config.first_observation_timeout + 1ms);
  ASSERT_TRUE(fx.end);
  EXPECT_EQ(fx.end->outcome, Outcome::Infrastructure);
}

// A capability of the episode's library with no live instance at the start is named in the episode's end,
// so a campaign can say its arm ran without it (a `full` without `vla_act`).
TEST_F(Machine, AnEpisodeEndSaysWhichCapabilitiesItRanWithout) {
  EpisodeSpec spec{0, "ep", "put the bowl on the plate", "full", 300};
  spec.library = {{"pick_place", {}}, {"vla_act", {}}};
  const auto end_of = [&](EpisodeMachine& machine) {
    return machine.on_tick(t0 + config.first_observation_timeout + 1ms).end;
  };
  EpisodeMachine without(spec, config, registry, *evidence, t0);
  const auto lacking = end_of(without);
  ASSERT_TRUE(lacking);
  EXPECT_EQ(lacking->capabilities_missing, std::vector<std::string>{"vla_act"});
  registry.announce(test::vla_act_info());
  EpisodeMachine whole(spec, config, registry, *evidence, t0);
  const auto complete = end_of(whole);
  ASSERT_TRUE(complete);
  EXPECT_TRUE(complete->capabilities_missing.empty());
}

TEST_F(Machine, TheSeamEndingTheEpisodeEndsItAtOnceWithTheSeamsReason) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  m->on_observation(test::scene_observation(3), t0);
  EXPECT_TRUE(nothing(m->on_seam_event({3, "ep/c0", SeamEventKind::SafetyHold, "wrist at 2.1 rad/s", {}})))
      << "a hold is recorded, and the command goes on";
  fx = m->on_seam_event(
      {3, "ep/c0", SeamEventKind::Ended, "the cell failed at step 3: the arm was stopped", {}});
  ASSERT_TRUE(fx.end) << "no wait for the step-stall deadline";
  EXPECT_EQ(fx.end->outcome, Outcome::Infrastructure);
  EXPECT_EQ(fx.end->steps, 3u);
  EXPECT_NE(fx.end->reason.find("the cell failed at step 3: the arm was stopped"), std::string::npos)
      << fx.end->reason;
  EXPECT_EQ(fx.cancel_command, "ep/c0");
  EXPECT_TRUE(nothing(m->on_seam_event({3, "ep/c0", SeamEventKind::Ended, "again", {}})))
      << "an ended episode does not end twice";
  const auto k = kinds();
  EXPECT_EQ(std::count(k.begin(), k.end(), "seam_ended"), 2);
  EXPECT_EQ(std::count(k.begin(), k.end(), "episode_end"), 1);
}

TEST_F(Machine, ACompletionReportedBeforeItsObservationWaitsForIt) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  m->on_observation(test::scene_observation(196), t0);
  fx = m->on_status({"ep/c0", "pick_place@a", CommandState::Completed, "", "done", 197, 197, 1}, t0);
  EXPECT_FALSE(fx.end);
  EXPECT_FALSE(fx.plan_request);
  Observation last = test::scene_observation(197);
  last.goal_holds = true;
  fx = m->on_observation(last, t0);
  ASSERT_TRUE(fx.end);
  EXPECT_TRUE(fx.end->success);
}

TEST_F(Machine, TheBareArmHandsTheWholeEpisodeToThePolicyWithoutAPlanner) {
  registry.announce(test::vla_act_info());
  config.mode = ExecutorMode::Bare;
  m = std::make_unique<EpisodeMachine>(EpisodeSpec{0, "ep", "put the bowl on the plate", "bare", 300}, config, registry,
                                       *evidence, t0);
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  EXPECT_FALSE(fx.plan_request);
  ASSERT_TRUE(fx.command);
  EXPECT_EQ(fx.command->capability, "vla_act");
  EXPECT_EQ(fx.command->args, (Bindings{{"instruction", "put the bowl on the plate"}}));
  EXPECT_EQ(fx.command->budget_steps, 300u) << "the bare policy gets the whole episode";
  // The policy's process fails at step 40: it is handed the rest, still without a planner.
  m->on_status({"ep/c0", "vla_act@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  for (std::uint32_t t = 1; t <= 40; ++t) m->on_observation(test::scene_observation(t), t0);
  fx = m->on_status({"ep/c0", "vla_act@a", CommandState::Failed, "policy: server gone", "infer", 40, 40, 0.3}, t0);
  ASSERT_TRUE(fx.command);
  EXPECT_FALSE(fx.plan_request);
  EXPECT_EQ(fx.command->budget_steps, 260u);
}

TEST_F(Machine, AStepWithNoAnalyticRouteLeftIsHandedToThePolicyWithTheInstruction) {
  registry.announce(test::vla_act_info());
  config.masked = {"pick_place"};
  m = std::make_unique<EpisodeMachine>(EpisodeSpec{0, "ep", "put the bowl on the plate", "no-analytic", 300}, config,
                                       registry, *evidence, t0);
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  ASSERT_TRUE(fx.plan_request);
  EXPECT_EQ(fx.plan_request->capabilities, std::vector<std::string>{"vla_act"});
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_FALSE(fx.command);
  ASSERT_TRUE(fx.plan_request) << "the masked pick_place is refused: the step goes back to the planner first";
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command) << "advised again, the refused step is handed to the policy";
  EXPECT_EQ(fx.command->capability, "vla_act");
  EXPECT_EQ(fx.command->args, (Bindings{{"instruction", "put the bowl on the plate"}}));
  EXPECT_EQ(fx.command->budget_steps, 160u) << "ceil(1.5 x 100) + 10";
}

TEST_F(Machine, TheBareArmWaitsBrieflyForThePolicysAnnouncement) {
  config.mode = ExecutorMode::Bare;
  m = std::make_unique<EpisodeMachine>(EpisodeSpec{0, "ep", "put the bowl on the plate", "bare", 300}, config, registry,
                                       *evidence, t0);
  EXPECT_FALSE(m->on_observation(test::scene_observation(0), t0).command) << "vla_act is not announced yet";
  EXPECT_FALSE(m->on_tick(t0 + 20ms).end);
  registry.announce(test::vla_act_info());
  const Effects fx = m->on_tick(t0 + 100ms);
  ASSERT_TRUE(fx.command) << "the episode goes on once the policy is there";
  EXPECT_EQ(fx.command->capability, "vla_act");

  // Without an announcement within the acknowledgement timeout the episode ends with the reason.
  Registry empty;
  EpisodeMachine lonely(EpisodeSpec{1, "ep2", "put the bowl on the plate", "bare", 300}, config, empty, *evidence, t0);
  lonely.on_observation(test::scene_observation(0), t0);
  Effects end;
  for (auto t = t0; !end.end && t < t0 + config.ack_timeout + 1s; t += 50ms) end = lonely.on_tick(t);
  ASSERT_TRUE(end.end);
  EXPECT_EQ(end.end->outcome, Outcome::GaveUp);
  EXPECT_NE(end.end->reason.find("vla_act"), std::string::npos) << end.end->reason;
}

// Recovery is chosen by the failure's code: the same code under any wording picks the same recovery, and
// a reason that says "grasp missed" without the code does not pick regrasp.
TEST_F(Machine, RecoveryIsChosenByTheFailureCodeNotItsWords) {
  struct Case {
    FailureCode code;
    std::string reason;
    std::string recovery;
  };
  const std::vector<Case> cases = {
      {FailureCode::GraspMissed, "grasp missed: the jaw closed on nothing", "regrasp"},
      {FailureCode::GraspMissed, "la pince s'est fermée sur le vide", "regrasp"},
      {FailureCode::GraspSlipped, "", "regrasp"},
      {FailureCode::ObjectDropped, "xyzzy", "regrasp"},
      {FailureCode::EntityLost, "grasp missed, slipped and dropped", "keyframe_return"},
      {FailureCode::None, "grasp missed", "keyframe_return"},
  };
  for (const auto& c : cases) {
    TearDown();
    SetUp();
    for (const char* name : {"regrasp", "keyframe_return", "release_retreat"}) {
      gov::CapabilityInfo r = test::pick_place_info(std::string(name) + "@a");
      r.capability = name;
      r.arguments = name == std::string("regrasp") ? std::vector<std::string>{"object"} : std::vector<std::string>{};
      r.preconditions = {};
      registry.announce(r);
    }
    Effects fx = m->on_observation(test::scene_observation(0), t0);
    fx = m->on_advice(good(fx.plan_request->request_id), t0);
    ASSERT_TRUE(fx.command);
    m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
    m->on_observation(test::scene_observation(5), t0);
    fx = m->on_status({"ep/c0", "pick_place@a", CommandState::Failed, c.reason, "close", 5, 5, 0.3, c.code}, t0);
    ASSERT_TRUE(fx.command) << to_string(c.code) << " / " << c.reason;
    EXPECT_EQ(fx.command->capability, c.recovery) << to_string(c.code) << " / " << c.reason;
  }
}

// DDS does not order the status and observation topics: a progress report of step 10 can overtake the
// observation of step 10. The decision at step 10 takes the reports of steps before 10 only, as it does
// in process (where the host reports step 10 after the governor has seen it).
TEST_F(Machine, AProgressReportThatOvertakesItsObservationIsNotSeenByThatStepsDecision) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  for (std::uint32_t t = 1; t < 10; ++t) m->on_observation(test::scene_observation(t), t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Running, "", "lift", 9, 9, 0.09}, t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Running, "", "lift", 10, 10, 0.5}, t0);  // early
  m->on_observation(test::scene_observation(10), t0);
  for (std::uint32_t t = 11; t < 20; ++t) m->on_observation(test::scene_observation(t), t0);
  m->on_observation(test::scene_observation(20), t0);
  std::vector<double> progress;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "decision") progress.push_back(r["progress"].get<double>());
  ASSERT_EQ(progress.size(), 2u);
  EXPECT_EQ(progress[0], 0.09) << "the report of step 10 reached the decision of step 10";
  EXPECT_EQ(progress[1], 0.5);
}

// A completion reported for a decision step before that step's observation: the step's decision comes
// first, then the completion, in the same order as in process.
TEST_F(Machine, ACompletionAtADecisionStepIsFinishedAfterThatStepsDecision) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  for (std::uint32_t t = 1; t < 20; ++t) m->on_observation(test::scene_observation(t), t0);
  fx = m->on_status({"ep/c0", "pick_place@a", CommandState::Completed, "", "done", 20, 20, 1}, t0);
  EXPECT_FALSE(fx.plan_request) << "waits for the observation of step 20";
  fx = m->on_observation(test::scene_observation(20), t0);
  ASSERT_TRUE(fx.plan_request) << "the completion asks for the next step";
  std::vector<std::string> causes;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "decision") causes.push_back(r["cause"].get<std::string>());
  ASSERT_EQ(causes.size(), 3u);
  EXPECT_EQ(causes[1], "decision step");
  EXPECT_EQ(causes[2], "command completed");
}

TEST_F(Machine, ASnapshotRestoresAMachineThatGoesOnAsTheOriginalDoes) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  m->on_status({"ep/c0", "pick_place@a", CommandState::Accepted, "", "", 0, 0, 0}, t0);
  const MachineSnapshot s = m->snapshot(t0);
  EXPECT_EQ(s.waits["deadline"].get<std::int64_t>(),
            std::chrono::duration_cast<std::chrono::nanoseconds>(config.step_stall_timeout).count())
      << "the next observation is due: a wait kept as time left";

  // Restored on another channel, later: the same state, and the same effects for the same events.
  const auto t1 = t0 + std::chrono::seconds(50);
  EvidenceWriter other(file.string() + ".restored");
  const auto restored = EpisodeMachine::restore(s, 3, config, registry, other, t1);
  EXPECT_EQ(restored->snapshot(t1).state, s.state);
  EXPECT_EQ(restored->snapshot(t1).waits, s.waits);
  EXPECT_EQ(restored->spec().channel, 3u);
  EXPECT_EQ(restored->decisions(), m->decisions());
  for (std::uint32_t t = 1; t <= 20; ++t) {
    const Effects a = m->on_observation(test::scene_observation(t), t0);
    const Effects b = restored->on_observation(test::scene_observation(t), t1);
    EXPECT_EQ(a.lease.has_value(), b.lease.has_value()) << t;
    if (a.lease && b.lease) {
      EXPECT_EQ(a.lease->valid_until_step, b.lease->valid_until_step) << t;
    }
  }
  EXPECT_EQ(restored->snapshot(t1).state, m->snapshot(t0).state);
  EXPECT_TRUE(m->on_tick(t0 + config.step_stall_timeout + 1ms).end.has_value() ==
              restored->on_tick(t1 + config.step_stall_timeout + 1ms).end.has_value());
  std::filesystem::remove(file.string() + ".restored");

  // Dispatched again under another library: the command in flight takes its θ and the given budget.
  const auto again = EpisodeMachine::restore(s, 0, config, registry, other, t1);
  const Effects r = again->redispatch("lib-x", {{"pick_place", {{"approach_height", 0.09}}}}, {{"pick_place", 150}}, 123, t1);
  ASSERT_TRUE(r.command);
  EXPECT_EQ(r.command->command_id, "ep/c0");
  EXPECT_EQ(r.command->theta.at("approach_height"), 0.09);
  EXPECT_EQ(r.command->budget_steps, 123u);
  ASSERT_TRUE(r.lease);
  EXPECT_EQ(r.lease->budget_until_step, r.command->start_step + 123);

  MachineSnapshot broken = s;
  broken.state.erase("latch");
  EXPECT_THROW(EpisodeMachine::restore(broken, 0, config, registry, other, t1), std::invalid_argument);
  std::filesystem::remove(file.string() + ".restored");
}
