// Grounding from perception: entities the perception service looked for are placed where it saw them;
// no, stale or unsure estimates make grounding wait for a fresh frame, then refuse with the reason.
#include <gtest/gtest.h>

#include <algorithm>

#include "dh/gov/episode.hpp"
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
      EXPECT_NE(r["reason"].get<std::string>().find("has not seen 'bowl'"), std::string::npos) << r.dump();
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
