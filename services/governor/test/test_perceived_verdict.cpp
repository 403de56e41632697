// The verdict from perception: the goal's terms on a perceived view, k frames in agreement before it
// changes, and the episode machine latching it (and not the simulator's) under verifier perception.
#include <gtest/gtest.h>

#include <cmath>

#include "dh/common/config.hpp"
#include "dh/gov/config.hpp"
#include "dh/gov/perceived_verdict.hpp"
#include "machine_fixture.hpp"

using namespace dh;
using namespace dh::gov;
using namespace std::chrono_literals;

namespace {

EntityState region(const std::string& name, std::array<double, 3> centre, std::array<double, 3> half, double yaw = 0) {
  EntityState e;
  e.name = name;
  e.kind = "region";
  e.p = centre;
  e.q = {std::cos(yaw / 2), 0, 0, std::sin(yaw / 2)};
  e.half_extents = half;
  return e;
}

EntityState part(const std::string& name, double joint) {
  EntityState e;
  e.name = name;
  e.kind = "drawer";
  e.joint = joint;
  return e;
}

/// The bowl (bottom at z 0) and the plate at y 0.15; the stove's cook region a 0.1 × 0.1 box whose top face
/// is at z 0.02; the cabinet's top drawer at `drawer` m.
Observation view(std::array<double, 3> bowl, double drawer = 0) {
  Observation o = test::scene_observation(0);
  o.entities[0].p = bowl;
  o.entities.push_back(region("stove_cook_region", {0.3, 0, 0.01}, {0.05, 0.05, 0.01}, 0.7));
  o.entities.push_back(region("cabinet_top_region", {-0.3, 0, 0.2}, {0.1, 0.1, 0.04}));
  o.entities.push_back(part("cabinet_top_drawer", drawer));
  return o;
}

const GoalTerm kOnPlate{"On", {"bowl", "plate"}, "", 0, 0};
const GoalTerm kOnStove{"On", {"bowl", "stove_cook_region"}, "", 0, 0};
const GoalTerm kInDrawer{"In", {"bowl", "cabinet_top_region"}, "", 0, 0};
const GoalTerm kDrawerOpen{"Open", {"cabinet_top_region"}, "cabinet_top_drawer", 0.14, 0.2};

TEST(TermHolds, OnAnObjectIsOverItAndRestingOnOrInIt) {
  EXPECT_TRUE(term_holds(kOnPlate, view({0.01, 0.16, 0.012})));
  EXPECT_FALSE(term_holds(kOnPlate, view({0.05, 0.15, 0.012}))) << "4 cm off its centre";
  EXPECT_FALSE(term_holds(kOnPlate, view({0, 0.15, 0.1}))) << "10 cm above the plate's top";
  EXPECT_FALSE(term_holds(kOnPlate, view({0, -0.15, 0}))) << "where it started";
}

TEST(TermHolds, OnARegionIsInsideItsFootprintOnItsTopFaceInTheRegionsOwnFrame) {
  EXPECT_TRUE(term_holds(kOnStove, view({0.3, 0, 0.02})));
  EXPECT_TRUE(term_holds(kOnStove, view({0.3, 0, 0.035}))) << "within the band above the surface";
  EXPECT_FALSE(term_holds(kOnStove, view({0.3, 0, 0.08}))) << "held over it, not resting";
  // The region is turned 0.7 rad: 0.045 along world x is outside its half size 0.05 along its own axes
  // only when rotated: (0.045, 0.045) is 0.064 from the centre, inside the box at 0.7 rad only if it
  // falls within both local half sizes.
  const double c = std::cos(0.7), s = std::sin(0.7);
  EXPECT_TRUE(term_holds(kOnStove, view({0.3 + 0.04 * c, 0.04 * s, 0.02}))) << "0.04 along the region's own x";
  EXPECT_FALSE(term_holds(kOnStove, view({0.3 + 0.06 * c, 0.06 * s, 0.02}))) << "0.06 along its own x";
}

// A cradle: the region's top face is its floor, 2 cm up; a bowl rests on the rails, the fixture's top at
// 6 cm. Either surface holds it within the footprint; a region beside its owner takes no such surface.
TEST(TermHolds, OnARegionOnAFixtureRestsOnItsFaceOrOnTheFixturesTop) {
  Observation o = view({0.3, 0.4, 0.06});
  EntityState rack = region("wine_rack", {0.3, 0.4, 0}, {0.08, 0.12, 0.03});
  rack.kind = "wine_rack";
  EntityState cradle = region("wine_rack_top_region", {0.3, 0.4, 0.015}, {0.075, 0.045, 0.005});
  cradle.owner = "wine_rack";
  cradle.relation = "on";
  o.entities.push_back(rack);
  o.entities.push_back(cradle);
  const GoalTerm on_rack{"On", {"bowl", "wine_rack_top_region"}, "", 0, 0};
  EXPECT_TRUE(term_holds(on_rack, o)) << "on the rails";
  o.entities[0].p = {0.3, 0.4, 0.025};
  EXPECT_TRUE(term_holds(on_rack, o)) << "on the cradle's floor";
  o.entities[0].p = {0.3, 0.4, 0.12};
  EXPECT_FALSE(term_holds(on_rack, o)) << "6 cm over the rails";
  o.entities[0].p = {0.3, 0.5, 0.06};
  EXPECT_FALSE(term_holds(on_rack, o)) << "on the rack, outside the region's footprint";
  o.entities[0].p = {0.3, 0.4, 0.06};
  o.entities.back().relation = "front_of";
  EXPECT_FALSE(term_holds(on_rack, o)) << "a region beside its owner: only its own face";
}

TEST(TermHolds, InARegionAndAPartsStateFromItsJoint) {
  EXPECT_TRUE(term_holds(kInDrawer, view({-0.3, 0, 0.17})));
  EXPECT_FALSE(term_holds(kInDrawer, view({-0.3, 0, 0.25}))) << "above the region's top";
  EXPECT_TRUE(term_holds(kDrawerOpen, view({0, 0, 0}, 0.16)));
  EXPECT_FALSE(term_holds(kDrawerOpen, view({0, 0, 0}, 0.05)));
}

TEST(TermHolds, AnObjectTheJawHoldsIsNotPlacedAndAnUnseenOneIsNowhere) {
  Observation held = view({0.01, 0.15, 0.012});
  held.ee_p = {0.01, 0.15, 0.05};
  held.gripper_opening = 0.05;
  held.contact_left = held.contact_right = true;
  EXPECT_FALSE(term_holds(kOnPlate, held)) << "still in the jaw";
  Observation unseen = view({0.01, 0.15, 0.012});
  unseen.entities.erase(unseen.entities.begin());
  EXPECT_FALSE(term_holds(kOnPlate, unseen));
}

TEST(CheckTerms, EachTermIsJudgedAsPerceivedAndOnTheSimulatorsPosesWhereThereAreAny) {
  const Observation seen = view({0.01, 0.15, 0.012}), truth = view({0.01, 0.15, 0.07}, 0.16);
  const auto checks = check_terms({kOnPlate, kDrawerOpen}, seen, truth);
  ASSERT_EQ(checks.size(), 2u);
  EXPECT_EQ(checks[0].term, "On(bowl, plate)");
  EXPECT_EQ(checks[0].subject, "bowl");
  EXPECT_TRUE(checks[0].perceived);
  EXPECT_EQ(checks[0].on_true_poses, false) << "7 cm above the plate's bottom in truth";
  ASSERT_TRUE(checks[0].seen && checks[0].truth);
  EXPECT_DOUBLE_EQ(checks[0].truth->p[2], 0.07);
  ASSERT_TRUE(checks[0].support_seen && checks[0].support_truth) << "the plate is an object";
  EXPECT_EQ(checks[0].support_seen->name, "plate");
  EXPECT_EQ(checks[1].support_seen, nullptr) << "a part's state has no support";
  EXPECT_EQ(check_terms({kInDrawer}, seen, truth)[0].support_seen, nullptr) << "nor has a region's term";
  EXPECT_EQ(checks[1].subject, "cabinet_top_drawer");
  EXPECT_FALSE(checks[1].perceived);
  EXPECT_EQ(checks[1].on_true_poses, true);
  Observation cell = truth;  // a cell's observation carries no poses of its objects
  cell.entities.clear();
  const auto on_cell = check_terms({kOnPlate}, seen, cell);
  EXPECT_FALSE(on_cell[0].on_true_poses.has_value());
  EXPECT_EQ(on_cell[0].truth, nullptr);
}

TEST(PerceivedVerdictFilter, ChangesOnlyAfterKFramesAgreeAndIgnoresOldFrames) {
  PerceivedVerdict v({kOnPlate}, 3);
  const Observation on = view({0, 0.15, 0.012}), off = view({0, -0.15, 0});
  EXPECT_FALSE(v.on_frame(10, on));
  EXPECT_FALSE(v.on_frame(20, off)) << "one false frame, then the run restarts";
  EXPECT_FALSE(v.on_frame(30, on));
  EXPECT_FALSE(v.on_frame(40, on));
  EXPECT_FALSE(v.on_frame(35, on)) << "an older frame does not count";
  // Another frame of the same step (the robot stands still, the camera keeps looking) does.
  const auto change = v.on_frame(40, on);
  ASSERT_TRUE(change);
  EXPECT_EQ(change->step, 40u);
  EXPECT_TRUE(change->value);
  EXPECT_TRUE(v.value());
  EXPECT_FALSE(v.on_frame(60, off));
  EXPECT_FALSE(v.on_frame(70, off));
  ASSERT_TRUE(v.on_frame(80, off)) << "it can be lost the same way";
  EXPECT_FALSE(v.value());
}

TEST(PerceivedVerdictFilter, AConjunctionNeedsEveryTermAndAnEmptyGoalNeverHolds) {
  PerceivedVerdict both({kInDrawer, kDrawerOpen}, 1);
  EXPECT_FALSE(both.on_frame(10, view({-0.3, 0, 0.17}, 0.05))) << "in the region, drawer shut";
  EXPECT_TRUE(both.on_frame(20, view({-0.3, 0, 0.17}, 0.16)));
  PerceivedVerdict none({}, 1);
  EXPECT_FALSE(none.on_frame(10, view({0, 0.15, 0.012})));
  EXPECT_THROW(PerceivedVerdict({kOnPlate}, 0), std::invalid_argument);
}

SceneEstimate frame(std::uint32_t step, std::array<double, 3> bowl) {
  SceneEstimate e{"ep", step, {"bowl", "plate"}, {}, {}};
  e.seen.push_back({"bowl", bowl, {0.065, 0.065, 0.025}, 0.9});
  e.seen.push_back({"plate", {0, 0.15, 0}, {0.09, 0.09, 0.006}, 0.9});
  return e;
}

struct PerceptionVerifier : test::MachineTest {
  void configure(GovernorConfig& c) override {
    c.perception = PerceptionLimits{};
    c.verifier = Verifier::Perception;
    c.verdict_frames = 2;
  }
  void configure_spec(EpisodeSpec& s) override { s.goal = {kOnPlate}; }
  /// The bowl seen where it starts; pick_place dispatched and completed at step 5 (no frame since); the
  /// planner says every step is complete. Returns what that advice did.
  Effects complete_the_plan() {
    m->on_observation(test::scene_observation(0), t0);
    Effects fx = m->on_scene_estimate(frame(0, {0, -0.15, 0}), t0);  // the first plan waits for it
    fx = m->on_advice(good(fx.plan_request->request_id), t0);
    EXPECT_TRUE(fx.command);
    CommandStatus done;
    done.command_id = fx.command->command_id;
    done.state = CommandState::Completed;
    done.step = 5;
    m->on_observation(test::scene_observation(5), t0 + 100ms);
    fx = m->on_status(done, t0 + 100ms);
    EXPECT_TRUE(fx.plan_request);
    const Advice finished{fx.plan_request->request_id, true, "", {}, "", "every step of the plan completed", "rules", true, {}};
    return m->on_advice(finished, t0 + 100ms);
  }
  std::vector<nlohmann::json> records(const std::string& kind) {
    std::vector<nlohmann::json> out;
    for (const auto& r : read_evidence(file))
      if (r["kind"] == kind) out.push_back(r);
    return out;
  }
};

TEST_F(PerceptionVerifier, TheSimulatorsVerdictIsRecordedButThePerceivedOneEndsTheEpisode) {
  m->on_observation(test::scene_observation(0), t0);
  Effects fx = m->on_scene_estimate(frame(0, {0, -0.15, 0}), t0);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  // The simulator says the goal holds; perception does not see it: no end.
  m->on_verdict(10, "On(bowl, plate)", true);
  Observation o = test::scene_observation(10);
  o.goal_holds = true;
  EXPECT_FALSE(m->on_observation(o, t0 + 500ms).end) << "the oracle does not decide under verifier perception";
  EXPECT_EQ(records("verdict_event").size(), 1u) << "but it is recorded";
  // Two frames with the bowl on the plate: the perceived verdict changes at the second.
  m->on_scene_estimate(frame(10, {0, 0.15, 0.012}), t0 + 500ms);
  EXPECT_TRUE(records("perceived_verdict").empty());
  m->on_scene_estimate(frame(20, {0, 0.15, 0.012}), t0 + 1s);
  const auto changes = records("perceived_verdict");
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0]["step"], 20);
  EXPECT_EQ(changes[0]["value"], true);
  EXPECT_EQ(changes[0]["oracle_at_observation"], true);
  o = test::scene_observation(20);
  fx = m->on_observation(o, t0 + 1s);
  ASSERT_TRUE(fx.end) << "the latched perceived verdict ends it at the decision step";
  EXPECT_TRUE(fx.end->success);
  const auto end = records("perceived_verdict_end");
  ASSERT_EQ(end.size(), 1u);
  EXPECT_EQ(end[0]["value"], true);
  // The end judges each term twice: the bowl is on the plate as perceived; the simulator's bowl, which
  // this test never moved, is not.
  ASSERT_EQ(end[0]["terms"].size(), 1u);
  const auto& term = end[0]["terms"][0];
  EXPECT_EQ(term["term"], "On(bowl, plate)");
  EXPECT_EQ(term["perceived"], true);
  EXPECT_EQ(term["on_true_poses"], false);
  EXPECT_EQ(term["seen"], nlohmann::json({0, 0.15, 0.012}));
  EXPECT_EQ(term["true"].size(), 3u);
  EXPECT_EQ(term["seen_from"], nlohmann::json({{"step", 20}, {"released", false}})) << "the frame that saw it";
  EXPECT_EQ(term["seen_half"], nlohmann::json({0.065, 0.065, 0.025})) << "its box as perceived";
  EXPECT_EQ(term["support_seen"], nlohmann::json({0, 0.15, 0})) << "the plate as perceived";
  EXPECT_EQ(term["support_true"].size(), 3u);
}

struct OracleWithPerception : PerceptionVerifier {
  void configure(GovernorConfig& c) override {
    PerceptionVerifier::configure(c);
    c.verifier = Verifier::Oracle;
  }
};

TEST_F(OracleWithPerception, ThePerceivedVerdictIsKeptBesideTheOraclesWithoutDecidingAnything) {
  m->on_observation(test::scene_observation(0), t0);
  Effects fx = m->on_scene_estimate(frame(0, {0, -0.15, 0}), t0);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  m->on_scene_estimate(frame(10, {0, 0.15, 0.012}), t0 + 500ms);
  m->on_scene_estimate(frame(20, {0, 0.15, 0.012}), t0 + 1s);
  EXPECT_EQ(records("perceived_verdict").size(), 1u);
  EXPECT_FALSE(m->on_observation(test::scene_observation(20), t0 + 1s).end) << "the oracle has not said so";
  m->on_verdict(25, "On(bowl, plate)", true);
  Observation o = test::scene_observation(30);
  o.goal_holds = true;
  fx = m->on_observation(o, t0 + 1500ms);
  ASSERT_TRUE(fx.end);
  EXPECT_TRUE(fx.end->success);
}

}  // namespace

namespace {

TEST(VerifierSettings, PerceptionNeedsPerceptionGroundingAndAGoalAndAnUnknownCodeIsRefused) {
  GovernorConfig base;
  EpisodeSpec spec{0, "ep", "put the bowl on the plate", "full", 300};
  spec.verifier = Verifier::Perception;
  spec.goal = {kOnPlate};
  spec.grounding = "state";
  EXPECT_THROW(for_request(base, spec), ConfigError) << "perception would not look";
  spec.grounding = "perception";
  EXPECT_EQ(for_request(base, spec).verifier, Verifier::Perception);
  spec.goal.clear();
  EXPECT_THROW(for_request(base, spec), ConfigError) << "no goal to judge";
  spec.verifier.reset();
  try {
    for_request(base, spec);
    FAIL() << "an unknown verifier code ran";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("verifier code"), std::string::npos) << e.what();
  }
}

}  // namespace

namespace {

TEST_F(PerceptionVerifier, APlanCompleteBeforeItsFramesWaitsForThePerceivedVerdict) {
  Effects fx = complete_the_plan();
  EXPECT_FALSE(fx.end) << "the frames lag the world: it waits";
  EXPECT_EQ(records("awaiting_verdict").size(), 1u);
  // Two frames of the still scene, the bowl on the plate: the perceived verdict follows and ends it.
  EXPECT_FALSE(m->on_scene_estimate(frame(5, {0, 0.15, 0.012}), t0 + 300ms).end);
  fx = m->on_scene_estimate(frame(5, {0, 0.15, 0.012}), t0 + 600ms);
  ASSERT_TRUE(fx.end);
  EXPECT_TRUE(fx.end->success);
  EXPECT_EQ(fx.end->outcome, Outcome::Success);
  EXPECT_TRUE(m->on_scene_estimate(frame(6, {0, 0.15, 0.012}), t0 + 900ms).plan_request == std::nullopt);
  EXPECT_EQ(records("perceived_verdict").size(), 1u) << "nothing is recorded after the end";
}

TEST_F(PerceptionVerifier, FramesOfTheFinalStateThatStayFalseGiveUpWithTheReason) {
  EXPECT_FALSE(complete_the_plan().end);
  // Frames of the final state with the bowl still where it started. However slowly they come (a loaded
  // machine), the wait is counted in them; a late frame of an earlier step does not count.
  EXPECT_FALSE(m->on_scene_estimate(frame(4, {0, -0.15, 0}), t0 + 200ms).end) << "an earlier step's frame";
  for (std::uint32_t k = 1; k < GovernorConfig{}.verdict_wait_frames; ++k)
    EXPECT_FALSE(m->on_scene_estimate(frame(5, {0, -0.15, 0}), t0 + k * 2s).end) << "frame " << k;
  const Effects fx = m->on_scene_estimate(frame(5, {0, -0.15, 0}), t0 + 25s);
  ASSERT_TRUE(fx.end);
  EXPECT_FALSE(fx.end->success);
  EXPECT_EQ(fx.end->outcome, Outcome::GaveUp);
  EXPECT_NE(fx.end->reason.find("perceived verdict stayed false over 12 frames of the final state"), std::string::npos)
      << fx.end->reason;
}

TEST_F(PerceptionVerifier, NoFramesOfTheFinalStateWithinTheWaitIsThePerceptionServiceLost) {
  EXPECT_FALSE(complete_the_plan().end);
  m->on_scene_estimate(frame(5, {0, -0.15, 0}), t0 + 1s);
  EXPECT_FALSE(m->on_tick(t0 + 30s).end) << "within the wait";
  const Effects fx = m->on_tick(t0 + 30101ms);
  ASSERT_TRUE(fx.end);
  EXPECT_FALSE(fx.end->success);
  EXPECT_EQ(fx.end->outcome, Outcome::Infrastructure);
  EXPECT_NE(fx.end->reason.find("perception: 1 of the 12 frames of the final state"), std::string::npos)
      << fx.end->reason;
}

}  // namespace
