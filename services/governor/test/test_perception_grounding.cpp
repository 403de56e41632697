// Planning and grounding from perception: entities the perception service looked for are placed where it
// saw them, and come in when the observation lacks them (a real cell's); no or stale estimates make
// planning and grounding wait for a fresh frame, and grounding then refuses with the reason.
#include <gtest/gtest.h>

#include <algorithm>

#include "dh/gov/episode.hpp"
#include "machine_fixture.hpp"

using namespace dh;
using namespace dh::gov;
using namespace std::chrono_literals;

namespace {

SceneEstimate estimate(std::uint32_t step, double bowl_confidence = 0.9) {
  SceneEstimate e{"ep", step, {"bowl", "plate"}, {}, {}};
  e.seen.push_back({"bowl", {0.01, -0.14, 0.002}, {0.066, 0.064, 0.026}, bowl_confidence});
  e.seen.push_back({"plate", {0.0, 0.15, 0.0}, {0.09, 0.09, 0.006}, 0.8});
  return e;
}

struct PerceptionMachine : test::MachineTest {
  void configure(GovernorConfig& c) override { c.perception = PerceptionLimits{}; }
};

TEST_F(PerceptionMachine, ThePlannerWaitsForTheFirstFrameThenPlansOnWhatPerceptionSaw) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  EXPECT_FALSE(fx.plan_request) << "no estimate yet: the planner is not asked on the observation's objects";
  EXPECT_FALSE(m->on_tick(t0 + 1s).plan_request) << "still within the wait";
  fx = m->on_scene_estimate(estimate(0), t0 + 1s);
  ASSERT_TRUE(fx.plan_request) << "the frame came: the planner is asked";
  const auto bowl = std::find_if(fx.plan_request->scene.begin(), fx.plan_request->scene.end(),
                                 [](const EntityState& e) { return e.name == "bowl"; });
  ASSERT_NE(bowl, fx.plan_request->scene.end());
  EXPECT_DOUBLE_EQ(bowl->p[0], 0.01) << "where perception saw it, not where the observation has it";
  bool waited = false;
  for (const auto& r : read_evidence(file))
    waited |= r["kind"] == "awaiting_perception" && r["for"] == "planning";
  EXPECT_TRUE(waited);
  ASSERT_TRUE(m->on_advice(good(fx.plan_request->request_id), t0 + 1s).command) << "the frame is fresh: grounded";
}

TEST_F(PerceptionMachine, AStepWaitsForTheFrameOfItsStepThenGroundsWithWhatPerceptionSaw) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_tick(t0 + 3001ms);
  ASSERT_TRUE(fx.plan_request) << "no frame within the wait: the planner is asked with what there is";
  fx = m->on_advice(good(fx.plan_request->request_id), t0 + 3001ms);
  EXPECT_FALSE(fx.command) << "no estimate yet: grounding waits";
  EXPECT_FALSE(fx.plan_request);
  EXPECT_FALSE(m->on_tick(t0 + 4s).command) << "still within the wait";
  EXPECT_FALSE(m->on_scene_estimate({"another-episode", 0, {"bowl"}, {}, {}}, t0 + 4s).command);
  fx = m->on_scene_estimate(estimate(0), t0 + 4s);
  ASSERT_TRUE(fx.command) << "the frame came: grounded";
  EXPECT_EQ(fx.command->args.at(0).second, "bowl");
}

// A real cell's observation carries its calibrated fixtures only: the objects perception saw come in as
// its description names them, for the planner and for grounding alike.
TEST_F(PerceptionMachine, OnACellWithoutFreeObjectsInItsObservationPerceivedObjectsComeIn) {
  Observation cell = test::scene_observation(0);
  cell.entities = {test::entity("stove", {0.3, 0.2, 0}, {0.1, 0.1, 0.05})};
  m->on_observation(cell, t0);
  SceneEstimate e = estimate(0);
  for (auto& seen : e.seen) {
    seen.kind = seen.name;
    seen.category = seen.name == "bowl" ? "bowl" : "dinner plate";
    seen.colour = "white";
  }
  const Effects fx = m->on_scene_estimate(e, t0);
  ASSERT_TRUE(fx.plan_request);
  const auto& scene = fx.plan_request->scene;
  ASSERT_EQ(scene.size(), 3u);
  const auto plate = std::find_if(scene.begin(), scene.end(), [](const EntityState& x) { return x.name == "plate"; });
  ASSERT_NE(plate, scene.end());
  EXPECT_EQ(plate->kind, "plate");
  EXPECT_EQ(plate->category, "dinner plate");
  EXPECT_EQ(plate->colour, "white");
  EXPECT_DOUBLE_EQ(plate->half_extents[0], 0.09);
  const Effects grounded = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(grounded.command) << "grounded on the perceived objects";
  EXPECT_EQ(grounded.command->args.at(1).second, "plate");
}

TEST_F(PerceptionMachine, AnEntityPerceptionCannotSeeIsRefusedAndNoOtherCapabilityIsTried) {
  m->on_observation(test::scene_observation(0), t0);
  Effects fx = m->on_scene_estimate(estimate(0, 0.05), t0);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  EXPECT_FALSE(fx.command);
  ASSERT_TRUE(fx.plan_request) << "refused: the planner is asked again";
  bool recorded = false;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "refusal" && r["refusal"] == "perception") {
      recorded = true;
      EXPECT_NE(r["reason"].get<std::string>().find("has not seen 'bowl'"), std::string::npos) << r.dump();
    }
  EXPECT_TRUE(recorded);
  EXPECT_TRUE(std::none_of(fx.plan_request->scene.begin(), fx.plan_request->scene.end(),
                           [](const EntityState& e) { return e.name == "bowl"; }))
      << "the planner's scene leaves out what perception did not see";
}

TEST_F(PerceptionMachine, NoFrameWithinTheWaitIsARefusalWithItsReason) {
  m->on_observation(test::scene_observation(0), t0);
  Effects fx = m->on_tick(t0 + 3001ms);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0 + 3001ms);
  EXPECT_FALSE(fx.command);
  fx = m->on_tick(t0 + 6002ms);
  EXPECT_FALSE(fx.command);
  ASSERT_TRUE(fx.plan_request) << "refused after the wait; the planner is asked again";
  bool recorded = false;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "refusal" && r["refusal"] == "perception")
      recorded |= r["reason"].get<std::string>().find("no scene estimate") != std::string::npos;
  EXPECT_TRUE(recorded);
}

// The perceived world and the perceived verdict's frames are in the snapshot: a machine restored from it
// goes on as the original does, the held bowl carried with the tool.
struct PerceptionVerdictMachine : PerceptionMachine {
  void configure_spec(EpisodeSpec& s) override { s.goal = {{"On", {"bowl", "plate"}, "", 0, 0}}; }
};

TEST_F(PerceptionVerdictMachine, ASnapshotHoldsThePerceivedWorldAndTheVerdictsFramesAndRestoresThem) {
  m->on_observation(test::scene_observation(0), t0);
  Effects fx = m->on_scene_estimate(estimate(0), t0);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  ASSERT_TRUE(fx.command);
  ASSERT_TRUE(fx.command->perception) << "the command grounds in perception";
  Observation held = test::scene_observation(1);  // the jaw closed over the perceived bowl
  held.ee_p = {0.01, -0.14, 0.03};
  held.contact_left = held.contact_right = true;
  held.gripper_opening = 0.05;
  m->on_observation(held, t0);
  m->on_scene_estimate(estimate(1), t0);

  const MachineSnapshot s = m->snapshot(t0);
  ASSERT_TRUE(s.state.contains("perceived_world"));
  EXPECT_EQ(s.state["perceived_world"]["held"], "bowl");
  EXPECT_EQ(s.state["perceived_world"]["latest"]["step"], 1);
  ASSERT_TRUE(s.state.contains("perceived_verdict"));
  EXPECT_EQ(s.state["perceived_verdict"]["last_step"], 1);
  EXPECT_EQ(s.state["running"]["perception"]["max_age_steps"], 20) << "the command's limits go with it";

  EvidenceWriter other(file.string() + ".restored");
  const auto restored = EpisodeMachine::restore(s, 0, config, registry, other, t0);
  EXPECT_EQ(restored->snapshot(t0).state, s.state);
  Observation carried = held;  // the tool carries the bowl towards the plate
  carried.step = 2;
  carried.ee_p = {0.0, 0.1, 0.12};
  for (EpisodeMachine* x : {m.get(), restored.get()}) {
    x->on_observation(carried, t0);
    x->on_scene_estimate(estimate(2), t0);
  }
  const nlohmann::json after = m->snapshot(t0).state;
  EXPECT_EQ(restored->snapshot(t0).state, after);
  EXPECT_NE(after["perceived_world"], s.state["perceived_world"]) << "the events moved the perceived bowl";

  GovernorConfig in_state = config;
  in_state.perception.reset();
  EXPECT_THROW(EpisodeMachine::restore(s, 0, in_state, registry, other, t0), std::invalid_argument)
      << "a snapshot taken grounding in perception, restored under an arm that grounds in state";
  std::filesystem::remove(file.string() + ".restored");
}

}  // namespace
