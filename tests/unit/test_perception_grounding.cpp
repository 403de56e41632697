// Grounding from perception: entities the perception service looked for are placed where it saw them;
// no, stale or unsure estimates make grounding wait for a fresh frame, then refuse with the reason.
#include <gtest/gtest.h>

#include <algorithm>

#include "dh/gov/episode.hpp"
#include "dh/gov/perception.hpp"
#include "machine_fixture.hpp"

using namespace dh;
using namespace dh::gov;
using namespace std::chrono_literals;

namespace {

SceneEstimate estimate(std::uint32_t step, double bowl_confidence = 0.9) {
  SceneEstimate e{"ep", step, {"bowl", "plate"}, {}};
  e.seen.push_back({"bowl", {0.01, -0.14, 0.002}, {0.066, 0.064, 0.026}, bowl_confidence});
  e.seen.push_back({"plate", {0.0, 0.15, 0.0}, {0.09, 0.09, 0.006}, 0.8});
  return e;
}

TEST(Perceive, SeenEntitiesTakeTheirEstimatedPlaceAndTheRestStay) {
  Observation obs = test::scene_observation(5);
  obs.entities.push_back({"stove", "stove", {0.3, 0.2, 0}, {1, 0, 0, 0}, {0.1, 0.1, 0.05}});
  SceneEstimate e = estimate(5);
  e.looked_for.push_back("mug");  // looked for, not seen
  obs.entities.push_back({"mug", "mug", {0.2, 0, 0}, {1, 0, 0, 0}, {0.04, 0.04, 0.05}});
  EXPECT_FALSE(perceive(obs, e, {"bowl", "plate"}, PerceptionLimits{}));
  ASSERT_NE(obs.entity("bowl"), nullptr);
  EXPECT_DOUBLE_EQ(obs.entity("bowl")->p[0], 0.01);
  EXPECT_DOUBLE_EQ(obs.entity("bowl")->half_extents[1], 0.064);
  ASSERT_NE(obs.entity("stove"), nullptr) << "what perception does not look for stays where the cell says";
  EXPECT_DOUBLE_EQ(obs.entity("stove")->p[0], 0.3);
  EXPECT_EQ(obs.entity("mug"), nullptr) << "looked for and not seen: not in the perceived scene";
}

TEST(Perceive, MissingStaleAndUnsureEstimatesAreNamed) {
  Observation obs = test::scene_observation(40);
  PerceptionLimits limits;
  auto why = perceive(obs, std::nullopt, {"bowl"}, limits);
  ASSERT_TRUE(why);
  EXPECT_TRUE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("no scene estimate"), std::string::npos) << why->reason;
  why = perceive(obs, estimate(10), {"bowl"}, limits);
  ASSERT_TRUE(why);
  EXPECT_TRUE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("from step 10, 30 steps old (limit 20)"), std::string::npos) << why->reason;
  why = perceive(obs, estimate(35, 0.1), {"bowl", "plate"}, limits);
  ASSERT_TRUE(why);
  EXPECT_FALSE(why->estimate_missing_or_stale);
  EXPECT_NE(why->reason.find("did not see 'bowl' in the frame of step 35 with enough confidence (0.10 < 0.30)"),
            std::string::npos)
      << why->reason;
  EXPECT_FALSE(perceive(obs, estimate(35, 0.1), {"plate"}, limits)) << "the bowl is not needed here";
}

struct PerceptionMachine : test::MachineTest {
  void configure(GovernorConfig& c) override { c.perception = PerceptionLimits{}; }
};

TEST_F(PerceptionMachine, AStepWaitsForTheFrameOfItsStepThenGroundsWithWhatPerceptionSaw) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  ASSERT_TRUE(fx.plan_request);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  EXPECT_FALSE(fx.command) << "no estimate yet: it waits";
  EXPECT_FALSE(fx.plan_request);
  EXPECT_FALSE(m->on_tick(t0 + 1s).command) << "still within the wait";
  EXPECT_FALSE(m->on_scene_estimate({"another-episode", 0, {"bowl"}, {}}, t0 + 1s).command);
  fx = m->on_scene_estimate(estimate(0), t0 + 1s);
  ASSERT_TRUE(fx.command) << "the frame came: grounded";
  EXPECT_EQ(fx.command->args.at(0).second, "bowl");
}

TEST_F(PerceptionMachine, AnEntityPerceptionCannotSeeIsRefusedAndNoOtherCapabilityIsTried) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  m->on_scene_estimate(estimate(0, 0.05), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  EXPECT_FALSE(fx.command);
  ASSERT_TRUE(fx.plan_request) << "refused: the planner is asked again";
  bool recorded = false;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "refusal" && r["refusal"] == "perception") {
      recorded = true;
      EXPECT_NE(r["reason"].get<std::string>().find("did not see 'bowl'"), std::string::npos) << r.dump();
    }
  EXPECT_TRUE(recorded);
  EXPECT_TRUE(std::none_of(fx.plan_request->scene.begin(), fx.plan_request->scene.end(),
                           [](const EntityState& e) { return e.name == "bowl"; }))
      << "the planner's scene leaves out what perception did not see";
}

TEST_F(PerceptionMachine, NoFrameWithinTheWaitIsARefusalWithItsReason) {
  Effects fx = m->on_observation(test::scene_observation(0), t0);
  fx = m->on_advice(good(fx.plan_request->request_id), t0);
  EXPECT_FALSE(fx.command);
  fx = m->on_tick(t0 + 3001ms);
  EXPECT_FALSE(fx.command);
  ASSERT_TRUE(fx.plan_request) << "refused after the wait; the planner is asked again";
  bool recorded = false;
  for (const auto& r : read_evidence(file))
    if (r["kind"] == "refusal" && r["refusal"] == "perception")
      recorded |= r["reason"].get<std::string>().find("no scene estimate") != std::string::npos;
  EXPECT_TRUE(recorded);
}

}  // namespace
