// The perceived world: objects where the frames saw them, remembered while hidden, carried by the hand
// while held; missing, stale or never-seen estimates are named.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "dh/common/perceived_world.hpp"
#include "fixtures.hpp"

using namespace dh;

namespace {

SceneEstimate estimate(std::uint32_t step, double bowl_confidence = 0.9, const std::string& episode = "ep") {
  SceneEstimate e{episode, step, {"bowl", "plate"}, {}, {}};
  e.seen.push_back({"bowl", {0.01, -0.14, 0.002}, {0.066, 0.064, 0.026}, bowl_confidence});
  e.seen.push_back({"plate", {0.0, 0.15, 0.0}, {0.09, 0.09, 0.006}, 0.8});
  return e;
}

SceneEstimate without_bowl(std::uint32_t step) {
  SceneEstimate e = estimate(step);
  e.seen.erase(e.seen.begin());
  return e;
}

Observation holding_at(std::uint32_t step, std::array<double, 3> ee) {
  Observation o = test::scene_observation(step);
  o.ee_p = ee;
  o.contact_left = o.contact_right = true;
  o.gripper_opening = 0.05;
  return o;
}

void expect_at(const Observation& o, const std::string& name, std::array<double, 3> p) {
  const EntityState* e = o.entity(name);
  ASSERT_NE(e, nullptr) << name;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(e->p[i], p[i], 1e-9) << name << " axis " << i;
}

TEST(PerceivedWorld, SeenEntitiesTakeTheirEstimatedPlaceAndTheRestStay) {
  PerceivedWorld w{PerceptionLimits{}};
  Observation obs = test::scene_observation(5);
  obs.entities.push_back(test::entity("stove", {0.3, 0.2, 0}, {0.1, 0.1, 0.05}));
  obs.entities.push_back(test::entity("mug", {0.2, 0, 0}, {0.04, 0.04, 0.05}, {0.7, 0, 0, 0.7}));
  obs.entities[0].q = {0.9, 0.1, 0, 0};
  SceneEstimate e = estimate(5);
  e.looked_for.push_back("mug");  // looked for, not seen
  w.on_estimate(e);
  EXPECT_FALSE(w.view(obs, {"bowl", "plate"}));
  expect_at(obs, "bowl", {0.01, -0.14, 0.002});
  EXPECT_DOUBLE_EQ(obs.entity("bowl")->half_extents[1], 0.064);
  EXPECT_DOUBLE_EQ(obs.entity("bowl")->q[0], 1) << "upright: perception estimates no tilt";
  expect_at(obs, "stove", {0.3, 0.2, 0});  // what perception does not look for stays where the cell says
  EXPECT_EQ(obs.entity("mug"), nullptr) << "looked for and never seen: not in the perceived scene";
  e.seen[1].yaw = 0.5;
  e.step = 6;
  w.on_estimate(e);
  obs = test::scene_observation(6);
  EXPECT_FALSE(w.view(obs, {"plate"}));
  const auto& q = obs.entity("plate")->q;
  EXPECT_NEAR(q[0], std::cos(0.25), 1e-12);
  EXPECT_NEAR(q[3], std::sin(0.25), 1e-12) << "the estimated yaw turns it about z";
  EXPECT_DOUBLE_EQ(q[1], 0);
}

TEST(PerceivedWorld, WhatTheObservationLacksComesInAsThePerceptionServiceNamesIt) {
  PerceivedWorld w{PerceptionLimits{}};
  Observation cell = test::scene_observation(3);
  cell.entities = {test::entity("stove", {0.3, 0.2, 0}, {0.1, 0.1, 0.05})};  // a cell's calibrated fixture
  SceneEstimate e = estimate(3);
  e.seen[0].kind = "bowl";
  e.seen[0].category = "bowl";
  e.seen[0].colour = "white";
  e.seen[0].yaw = 0.4;
  e.looked_for.push_back("mug");  // looked for, never seen: it does not come in
  w.on_estimate(e);
  EXPECT_FALSE(w.view(cell, {"bowl"}));
  ASSERT_EQ(cell.entities.size(), 3u);
  expect_at(cell, "bowl", {0.01, -0.14, 0.002});
  const EntityState& bowl = *cell.entity("bowl");
  EXPECT_EQ(bowl.kind, "bowl");
  EXPECT_EQ(bowl.category, "bowl");
  EXPECT_EQ(bowl.colour, "white");
  EXPECT_DOUBLE_EQ(bowl.half_extents[0], 0.066);
  EXPECT_NEAR(bowl.q[3], std::sin(0.2), 1e-12);
  expect_at(cell, "stove", {0.3, 0.2, 0});
  EXPECT_EQ(cell.entity("mug"), nullptr);
  // Held, it moves with the tool as an observed object does.
  Observation held = holding_at(4, {0.01, -0.14, 0.03});
  held.entities = {};
  EXPECT_FALSE(w.view(held, {"bowl"}));
  held = holding_at(5, {0.11, -0.04, 0.13});
  held.entities = {};
  EXPECT_FALSE(w.view(held, {"bowl"}));
  EXPECT_NEAR(held.entity("bowl")->p[0], 0.11, 1e-9);
}

TEST(PerceivedWorld, MissingStaleAndNeverSeenEstimatesAreNamed) {
  PerceivedWorld w{PerceptionLimits{}};
  Observation obs = test::scene_observation(40);
  auto why = w.view(obs, {"bowl"});
  ASSERT_TRUE(why);
  EXPECT_TRUE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("no scene estimate"), std::string::npos) << why->reason;
  w.on_estimate(estimate(10, 0.1));
  why = w.view(obs, {"bowl"});
  ASSERT_TRUE(why);
  EXPECT_TRUE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("from step 10, 30 steps old (limit 20)"), std::string::npos) << why->reason;
  w.on_estimate(estimate(35, 0.1));
  why = w.view(obs, {"bowl", "plate"});
  ASSERT_TRUE(why);
  EXPECT_FALSE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("has not seen 'bowl' in this episode (latest frame: step 35, confidence 0.10 < 0.30)"),
            std::string::npos)
      << why->reason;
  obs = test::scene_observation(40);
  EXPECT_FALSE(w.view(obs, {"plate"})) << "the bowl is not needed here";
  EXPECT_EQ(obs.entity("bowl"), nullptr);
}

TEST(PerceivedWorld, AnObjectHiddenInALaterFrameKeepsItsLastSeenPlace) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  w.on_estimate(without_bowl(10));  // the arm reaching for it hides it
  Observation obs = test::scene_observation(12);
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.01, -0.14, 0.002});
  w.on_estimate(estimate(5));  // an older frame arriving late changes nothing
  EXPECT_EQ(w.latest()->step, 10u);
}

TEST(PerceivedWorld, AHeldObjectMovesWithTheToolAndStaysWhereItIsLetGo) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  Observation obs = holding_at(10, {0.01, -0.14, 0.05});
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.01, -0.14, 0.002});
  EXPECT_TRUE(obs.in_jaw(*obs.entity("bowl")));
  // Frames taken while it is in the hand see fragments of it; they do not move it.
  SceneEstimate in_hand = estimate(20);
  in_hand.seen[0].p = {0.2, 0.3, 0.1};
  w.on_estimate(in_hand);
  obs = holding_at(25, {0.1, 0.1, 0.2});
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.1, 0.1, 0.152});
  EXPECT_TRUE(obs.in_jaw(*obs.entity("bowl"))) << "the skill still sees it in the jaw";
  // Let go above the plate: it stays there, and a frame taken before the release does not undo that.
  obs = test::scene_observation(30);
  obs.ee_p = {0, 0.15, 0.06};
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0, 0.15, 0.012});
  in_hand.step = 28;
  w.on_estimate(in_hand);
  obs = test::scene_observation(31);
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0, 0.15, 0.012});
  SceneEstimate after = estimate(40);
  after.seen[0].p = {0.001, 0.151, 0.007};
  w.on_estimate(after);
  obs = test::scene_observation(41);
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.001, 0.151, 0.007});
}

// The hand is tracked at every step: an object let go between two views stays where it was let go, not
// where the retreating tool is at the next view.
TEST(PerceivedWorld, AReleaseBetweenViewsIsPlacedAtTheStepItHappened) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  w.track(holding_at(10, {0.01, -0.14, 0.05}));  // taken at the grasp
  w.track(holding_at(20, {0, 0.15, 0.06}));      // carried over the plate
  Observation released = test::scene_observation(21);
  released.ee_p = {0, 0.15, 0.06};
  w.track(released);                             // let go there
  w.on_estimate(without_bowl(25));               // a frame that does not see it
  Observation retreated = test::scene_observation(30);
  retreated.ee_p = {0, 0.15, 0.16};              // the tool 10 cm higher at the next view
  EXPECT_FALSE(w.view(retreated, {"bowl"}));
  expect_at(retreated, "bowl", {0, 0.15, 0.012});
}

TEST(PerceivedWorld, FramesTakenWhileTheHandIsOverAnObjectDoNotMoveIt) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  Observation obs = test::scene_observation(8);
  obs.ee_p = {0.02, -0.13, 0.1};  // descending onto the bowl
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  SceneEstimate occluded = estimate(10);
  occluded.seen[0].p = {0.04, -0.1, 0.002};  // the part the hand leaves visible
  w.on_estimate(occluded);
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.01, -0.14, 0.002});
  obs = test::scene_observation(20);  // the hand went back up and away
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  occluded.step = 20;
  w.on_estimate(occluded);
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.04, -0.1, 0.002});
}

// What the jaw lets go falls. The open hand, risen 10 cm, is still over it, yet a frame that sees it where
// it was let go places it at the height it fell to; a frame that sees it elsewhere under the hand does not.
TEST(PerceivedWorld, ALetGoObjectSettlesWhereAFrameSeesItBelowTheHand) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  w.track(holding_at(10, {0.01, -0.14, 0.05}));
  w.track(holding_at(20, {0, 0.15, 0.09}));  // carried 4 cm higher than it was taken
  Observation let_go = test::scene_observation(21);
  let_go.ee_p = {0, 0.15, 0.09};
  w.track(let_go);
  Observation above = test::scene_observation(22);
  above.ee_p = {0, 0.15, 0.19};  // the open hand risen 10 cm
  w.track(above);
  EXPECT_EQ(w.placement("bowl")->released, true);
  SceneEstimate shifted = estimate(25);
  shifted.seen[0].p = {0.03, 0.17, 0.01};  // 3.6 cm off, under the hand: a fragment
  w.on_estimate(shifted);
  Observation obs = test::scene_observation(26);
  obs.ee_p = above.ee_p;
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0, 0.15, 0.042});
  SceneEstimate fallen = estimate(30);
  fallen.seen[0].p = {0.005, 0.152, 0.007};
  w.on_estimate(fallen);
  obs = test::scene_observation(31);
  obs.ee_p = above.ee_p;
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.005, 0.152, 0.007});
  EXPECT_EQ(w.placement("bowl")->released, false);
  EXPECT_EQ(w.placement("bowl")->step, 30u);
  EXPECT_FALSE(w.placement("mug")) << "never seen";
}

// An object with another resting on it is partly hidden, as under the hand: frames do not move it until
// the other is taken away.
TEST(PerceivedWorld, AnObjectWithAnotherRestingOnItKeepsItsPlace) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  SceneEstimate stacked = estimate(10);
  stacked.seen[0].p = {0.01, 0.16, 0.012};  // the bowl on the plate
  stacked.seen[1].p = {0.04, 0.12, 0.0};    // the plate, its visible rim only
  w.on_estimate(stacked);
  Observation obs = test::scene_observation(11);
  EXPECT_FALSE(w.view(obs, {"bowl", "plate"}));
  expect_at(obs, "bowl", {0.01, 0.16, 0.012});
  expect_at(obs, "plate", {0.0, 0.15, 0.0});  // the frame that sees the bowl on it does not move it
  std::swap(stacked.seen[0], stacked.seen[1]);  // the order of a frame's estimates does not matter
  stacked.step = 20;
  w.on_estimate(stacked);
  obs = test::scene_observation(21);
  EXPECT_FALSE(w.view(obs, {"plate"}));
  expect_at(obs, "plate", {0.0, 0.15, 0.0});
  SceneEstimate cleared = estimate(30);  // the bowl back where it was: the plate shows whole again
  cleared.seen[1].p = {0.002, 0.151, 0.0};
  w.on_estimate(cleared);
  obs = test::scene_observation(31);
  EXPECT_FALSE(w.view(obs, {"plate"}));
  expect_at(obs, "plate", {0.002, 0.151, 0.0});
}

TEST(PerceivedWorld, TheClosedJawCorrectsAPerceivedPlaceThatMissesIt) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  // The jaw closed 2 cm beyond the perceived footprint's edge (0.066 from the centre in x): it holds the
  // bowl all the same, which must then be where the tool is.
  Observation obs = holding_at(10, {0.01 + 0.086, -0.14, 0.05});
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  const EntityState* bowl = obs.entity("bowl");
  ASSERT_NE(bowl, nullptr);
  EXPECT_NEAR(bowl->p[0], 0.01 + 0.086 - 0.066, 1e-9) << "pulled in until the tool is on its footprint's edge";
  EXPECT_TRUE(obs.in_jaw(*bowl));
}

TEST(PerceivedWorld, AFootprintTurnsWithTheEstimatedYaw) {
  PerceivedWorld w{PerceptionLimits{}};
  SceneEstimate e = estimate(0);
  e.seen[0].half_extents = {0.1, 0.02, 0.026};  // a long box, its long side along world y
  e.seen[0].yaw = M_PI / 2;
  w.on_estimate(e);
  Observation obs = holding_at(10, {0.01, -0.14 + 0.08, 0.04});  // near one end of it
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  obs = holding_at(12, {0.2, 0.2, 0.1});
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.2, 0.2 - 0.08, 0.062});  // held: it went with the tool
}

TEST(PerceivedWorld, AClosedJawWithNothingPerceivedInItCarriesNothing) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(0));
  Observation obs = holding_at(10, {0.3, 0.3, 0.05});  // far from every perceived object
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  obs = holding_at(12, {0.35, 0.3, 0.05});
  EXPECT_FALSE(w.view(obs, {"bowl"}));
  expect_at(obs, "bowl", {0.01, -0.14, 0.002});
}

TEST(PerceivedWorld, AnotherEpisodesFrameStartsAfresh) {
  PerceivedWorld w{PerceptionLimits{}};
  w.on_estimate(estimate(50));
  SceneEstimate next = without_bowl(0);
  next.episode_id = "ep2";
  w.on_estimate(next);
  EXPECT_EQ(w.latest()->episode_id, "ep2");
  Observation obs = test::scene_observation(2);
  const auto why = w.view(obs, {"bowl"});
  ASSERT_TRUE(why) << "the bowl of the last episode is forgotten";
  EXPECT_NE(why->reason.find("has not seen 'bowl'"), std::string::npos) << why->reason;
}

TEST(PerceivedWorld, AFittedPartTakesItsJointValueAndCarriesItsRegionsTheCalibratedOnesStay) {
  PerceivedWorld w{PerceptionLimits{}};
  const auto observed = [] {
    Observation o = test::scene_observation(20);
    EntityState drawer = test::entity("unit_drawer", {-0.04, 0.3, 0.05}, {0.005, 0.035, 0.006});
    drawer.joint = 0;  // the calibration's: shut
    o.entities.push_back(drawer);
    o.entities.push_back(test::entity("unit_drawer_region", {0.1, 0.3, 0.05}, {0.09, 0.1, 0.03}));
    o.entities.push_back(test::entity("unit_top_side", {0.1, 0.3, 0.12}, {0.1, 0.12, 0.005}));
    return o;
  };
  SceneEstimate e = estimate(20);
  e.parts.push_back({"unit_drawer", 0.15, 0.8, {{"unit_drawer", {-0.19, 0.3, 0.05}, {1, 0, 0, 0}}, {"unit_drawer_region", {-0.05, 0.3, 0.05}, {1, 0, 0, 0}}}});
  w.on_estimate(e);
  Observation obs = observed();
  ASSERT_FALSE(w.view(obs, {}));
  EXPECT_NEAR(obs.entity("unit_drawer")->joint, 0.15, 1e-12);
  expect_at(obs, "unit_drawer", {-0.19, 0.3, 0.05});
  expect_at(obs, "unit_drawer_region", {-0.05, 0.3, 0.05});
  expect_at(obs, "unit_top_side", {0.1, 0.3, 0.12});  // on the fixture's body: calibrated

  // A fit below the confidence floor changes nothing: the last confident one stands.
  SceneEstimate unsure = estimate(30);
  unsure.parts.push_back({"unit_drawer", 0.02, 0.1, {{"unit_drawer", {-0.06, 0.3, 0.05}, {1, 0, 0, 0}}}});
  w.on_estimate(unsure);
  obs = observed();
  obs.step = 30;
  ASSERT_FALSE(w.view(obs, {}));
  EXPECT_NEAR(obs.entity("unit_drawer")->joint, 0.15, 1e-12);

  // A parts camera's own frame moves the parts and leaves the objects' latest frame as it was.
  SceneEstimate parts_only{"ep", 40, {}, {}, {}};
  parts_only.parts.push_back({"unit_drawer", 0.1, 0.8, {{"unit_drawer", {-0.14, 0.3, 0.05}, {1, 0, 0, 0}}}});
  w.on_estimate(parts_only);
  EXPECT_EQ(w.latest()->step, 30u) << "a parts frame is not a frame of the objects";
  obs = observed();
  obs.step = 40;
  ASSERT_FALSE(w.view(obs, {}));
  EXPECT_NEAR(obs.entity("unit_drawer")->joint, 0.1, 1e-12);
  expect_at(obs, "unit_drawer", {-0.14, 0.3, 0.05});
  // Another episode's parts frame starts afresh.
  parts_only.episode_id = "ep2";
  w.on_estimate(parts_only);
  EXPECT_EQ(w.episode(), "ep2");
  EXPECT_FALSE(w.latest()) << "the last episode's objects are forgotten";

  // Without any fit the observation's value stands.
  PerceivedWorld no_parts{PerceptionLimits{}};
  no_parts.on_estimate(estimate(20));
  obs = observed();
  ASSERT_FALSE(no_parts.view(obs, {}));
  EXPECT_EQ(obs.entity("unit_drawer")->joint, 0);
}

TEST(PerceivedWorld, ItsStateRestoresAWorldThatViewsAndGoesOnAsTheOriginal) {
  PerceivedWorld w{PerceptionLimits{}};
  SceneEstimate e = estimate(4);
  e.parts.push_back({"drawer", 0.12, 0.9, {{"drawer", {0.3, 0.1, 0.2}, {0.9, 0, 0, 0.43589}}}});
  w.on_estimate(e);
  w.track(holding_at(5, {0.01, -0.14, 0.03}));  // the jaw closes on the bowl
  const nlohmann::json state = w.state();
  PerceivedWorld back = PerceivedWorld::from_state(state, PerceptionLimits{});
  EXPECT_EQ(back.state(), state);
  EXPECT_EQ(back.episode(), "ep");
  for (PerceivedWorld* x : {&w, &back}) x->track(holding_at(6, {0.2, 0.1, 0.15}));
  Observation a = holding_at(6, {0.2, 0.1, 0.15}), b = a;
  a.entities.push_back(test::entity("drawer", {0, 0, 0}, {0.1, 0.1, 0.1}));
  b.entities = a.entities;
  ASSERT_FALSE(w.view(a, {"bowl"}));
  ASSERT_FALSE(back.view(b, {"bowl"}));
  ASSERT_NE(a.entity("bowl"), nullptr);
  EXPECT_EQ(a.entity("bowl")->p, b.entity("bowl")->p) << "carried with the tool in both";
  EXPECT_EQ(a.entity("drawer")->joint, 0.12);
  EXPECT_EQ(b.entity("drawer")->joint, 0.12);
  EXPECT_EQ(b.entity("drawer")->p, a.entity("drawer")->p);
  EXPECT_THROW(PerceivedWorld::from_state({{"episode", "ep"}}, PerceptionLimits{}), std::invalid_argument);
}

}  // namespace
