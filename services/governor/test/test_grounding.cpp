#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "dh/common/config.hpp"
#include "dh/gov/config.hpp"
#include "dh/gov/grounding.hpp"
#include "dh/gov/ports.hpp"
#include "fixtures.hpp"

using namespace dh;
using namespace dh::gov;

namespace {
struct Grounding : ::testing::Test {
  Registry registry;
  Observation obs = test::scene_observation(40);
  std::set<std::string> masked;
  std::map<std::string, std::map<std::string, double>> library;
  std::map<std::string, std::uint32_t> costs;
  Advice advice{"p0", false, "pick_place", {{"object", "bowl"}, {"target", "plate"}}, "", "", "rules", false, {}};
  void SetUp() override { registry.announce(test::pick_place_info()); }
  GroundingResult run(std::uint32_t remaining = 260) {
    return ground({advice, registry, obs, remaining, masked, "ep/c0", 10, library, costs});
  }
};
}  // namespace

TEST_F(Grounding, AGroundedCommandCarriesBudgetLeaseAndTheta) {
  const auto g = run();
  ASSERT_TRUE(g.command) << g.reason;
  EXPECT_EQ(g.command->instance, "pick_place@a");
  EXPECT_EQ(g.command->start_step, 40u);
  EXPECT_EQ(g.command->lease_until_step, 50u) << "the lease runs to the next decision step";
  EXPECT_EQ(g.command->budget_steps, command_budget(221, 260));
  EXPECT_EQ(g.command->budget_steps, 260u) << "ceil(221 * 1.5) + 10 = 342, capped at the 260 steps left";
  EXPECT_DOUBLE_EQ(g.command->theta.at("corridor_height"), 0.16);
}

TEST_F(Grounding, ThePlannersRefusalIsRecordedAsSuch) {
  advice.refused = true;
  advice.reason = "cannot parse";
  const auto g = run();
  EXPECT_FALSE(g.command);
  EXPECT_EQ(g.refusal, Refusal::PlannerRefused);
  EXPECT_NE(g.reason.find("cannot parse"), std::string::npos);
}

TEST_F(Grounding, WhyThePlannerRefusedIsKeptAsItsCode) {
  advice.refused = true;
  advice.reason = "cannot connect";
  advice.why = PlannerRefusal::Unavailable;
  auto g = run();
  EXPECT_EQ(g.refusal, Refusal::PlannerUnavailable);
  EXPECT_STREQ(to_string(g.refusal), "planner_unavailable");
  advice.why = PlannerRefusal::Malformed;
  g = run();
  EXPECT_EQ(g.refusal, Refusal::PlannerMalformed);
  EXPECT_STREQ(to_string(g.refusal), "planner_malformed");
  advice.why = PlannerRefusal::Planning;
  EXPECT_EQ(run().refusal, Refusal::PlannerRefused);
}

TEST_F(Grounding, UnknownCapability) {
  advice.capability = "teleport";
  EXPECT_EQ(run().refusal, Refusal::UnknownCapability);
}

TEST_F(Grounding, CapabilityNotAlive) {
  registry.set_alive("pick_place@a", false);
  EXPECT_EQ(run().refusal, Refusal::CapabilityNotAlive);
}

TEST_F(Grounding, CapabilityMasked) {
  masked.insert("pick_place");
  EXPECT_EQ(run().refusal, Refusal::CapabilityMasked);
}

TEST_F(Grounding, MissingArgument) {
  advice.args = {{"object", "bowl"}};
  const auto g = run();
  EXPECT_EQ(g.refusal, Refusal::MissingArgument);
  EXPECT_NE(g.reason.find("target"), std::string::npos);
}

TEST_F(Grounding, UnresolvedEntity) {
  advice.args = {{"object", "mug"}, {"target", "plate"}};
  const auto g = run();
  EXPECT_EQ(g.refusal, Refusal::UnresolvedEntity);
  EXPECT_NE(g.reason.find("mug"), std::string::npos);
}

TEST_F(Grounding, PreconditionDistinctEntities) {
  advice.args = {{"object", "bowl"}, {"target", "bowl"}};
  EXPECT_EQ(run().refusal, Refusal::Precondition);
}

TEST_F(Grounding, PreconditionGripperEmpty) {
  obs.contact_left = obs.contact_right = true;
  obs.gripper_opening = 0.01;
  const auto g = run();
  EXPECT_EQ(g.refusal, Refusal::Precondition);
  EXPECT_NE(g.reason.find("holds"), std::string::npos);
}

TEST_F(Grounding, PreconditionAlreadyDone) {
  obs.goal_holds = true;
  EXPECT_EQ(run().refusal, Refusal::Precondition);
}

TEST_F(Grounding, BudgetCannotPayForTheCostModel) {
  const auto g = run(200);
  EXPECT_EQ(g.refusal, Refusal::Budget);
  EXPECT_NE(g.reason.find("200 steps remain"), std::string::npos);
}

TEST_F(Grounding, HotSwapRoutesToTheNewestLiveInstance) {
  registry.announce(test::pick_place_info("pick_place@b", 2));
  EXPECT_EQ(run().command->instance, "pick_place@b");
  registry.set_alive("pick_place@b", false);
  EXPECT_EQ(run().command->instance, "pick_place@a");
}

TEST_F(Grounding, ADrainingInstanceIsSkippedNotRefused) {
  auto newer = test::pick_place_info("pick_place@b", 2);
  newer.draining = true;
  registry.announce(newer);
  EXPECT_EQ(run().command->instance, "pick_place@a") << "the older instance takes the command";
  EXPECT_TRUE(registry.alive("pick_place@b")) << "its running command goes on";
  registry.set_alive("pick_place@a", false);
  const auto g = run();
  EXPECT_FALSE(g.command) << "no instance takes new commands";
  EXPECT_EQ(g.refusal, Refusal::CapabilityNotAlive) << g.reason;
  EXPECT_TRUE(registry.alive_capabilities().empty()) << "the planner is not offered it";
}

TEST_F(Grounding, TheLibrarysCostUnderItsThetaBudgetsTheCommandNotTheAnnouncedOne) {
  // The instance announced 221 steps; the episode's library runs a θ that costs 150: that is what the
  // command must fit and is budgeted by, as the skill itself checks it under that θ.
  costs["pick_place"] = 150;
  auto g = run(200);
  ASSERT_TRUE(g.command) << g.reason;
  EXPECT_EQ(g.command->budget_steps, command_budget(150, 200));
  costs["pick_place"] = 250;
  g = run(240);
  EXPECT_FALSE(g.command);
  EXPECT_EQ(g.refusal, Refusal::Budget);
  EXPECT_NE(g.reason.find("costs 250"), std::string::npos) << g.reason;
}

TEST(CommandBudget, NeverMoreThanWhatRemains) {
  EXPECT_EQ(command_budget(221, 100), 100u);
  EXPECT_EQ(command_budget(100, 1000), 160u);
}

TEST(CommandBudget, ALongerPlanRaisesItAndNothingLowersIt) {
  EXPECT_EQ(raised_budget(160, 150, 1000), command_budget(150, 1000));
  EXPECT_EQ(raised_budget(160, 150, 200), 200u) << "within what the episode had left at the start";
  EXPECT_EQ(raised_budget(160, 90, 1000), 160u) << "a plan shorter than the cost leaves the budget";
  EXPECT_EQ(raised_budget(160, 0, 1000), 160u) << "a status that does not say its plan leaves it";
  EXPECT_EQ(raised_budget(250, 150, 200), 250u) << "never lowered";
}

TEST_F(Grounding, AHandHoldingSomethingElseIsRefusedButItsOwnObjectIsFine) {
  obs.contact_left = obs.contact_right = true;
  obs.gripper_opening = 0.02;
  obs.ee_p = {0, 0.15, 0.1};  // over the plate, not the bowl
  auto g = run();
  ASSERT_FALSE(g.command);
  EXPECT_EQ(g.refusal, Refusal::Precondition);
  EXPECT_NE(g.reason.find("already holds"), std::string::npos) << g.reason;
  obs.ee_p = {0.01, -0.15, 0.04};  // the bowl (the command's object) is in the jaw: a regrasp took it
  g = run();
  EXPECT_TRUE(g.command) << g.reason;
}

TEST_F(Grounding, TheEpisodesLibraryGivesTheThetaInsteadOfTheAnnouncedOne) {
  library["pick_place"] = {{"corridor_height", 0.2}, {"approach_height", 0.07}};
  library["push"] = {{"contact_offset", 0.01}};
  const auto g = run();
  ASSERT_TRUE(g.command) << g.reason;
  EXPECT_EQ(g.command->theta, library["pick_place"]) << "the library's θ, whole; not merged with the announced one";
  library.erase("pick_place");
  EXPECT_DOUBLE_EQ(run().command->theta.at("corridor_height"), 0.16) << "a capability the library lacks: announced θ";
}

TEST(Readiness, AnEpisodeWaitsForTheCapabilitiesItsArmMayUse) {
  EpisodeSpec spec{0, "ep", "put the bowl on the plate", "full", 300};
  spec.library = {{"pick_place", {}}, {"push", {}}, {"vla_act", {}}};
  GovernorConfig full;
  EXPECT_EQ(needed_capabilities(full, spec), (std::set<std::string>{"pick_place", "push", "vla_act"}));
  GovernorConfig no_vla;
  no_vla.masked = {"vla_act"};
  EXPECT_EQ(needed_capabilities(no_vla, spec), (std::set<std::string>{"pick_place", "push"}));
  GovernorConfig bare;
  bare.mode = ExecutorMode::Bare;
  EXPECT_EQ(needed_capabilities(bare, spec), (std::set<std::string>{"vla_act"}));

  Registry registry;
  registry.announce(test::pick_place_info());
  EXPECT_EQ(registry.missing(needed_capabilities(no_vla, spec)), (std::vector<std::string>{"push"}));
  auto draining = test::pick_place_info("push@a");
  draining.capability = "push";
  draining.draining = true;
  registry.announce(draining);
  EXPECT_EQ(registry.missing(needed_capabilities(no_vla, spec)), (std::vector<std::string>{"push"}))
      << "a draining instance takes no new command: not ready";
  draining.draining = false;
  registry.announce(draining);
  EXPECT_TRUE(registry.missing(needed_capabilities(no_vla, spec)).empty());
}

TEST(EpisodeSettings, TheRequestSetsThePeriodTheGroundingAndTheLimits) {
  GovernorConfig base;
  base.decision_period = 10;
  EpisodeSpec spec{0, "ep", "put the bowl on the plate", "full", 300};
  spec.decision_period = 5;
  spec.grounding = "perception";
  spec.perception = PerceptionLimits{7, 0.5, std::chrono::milliseconds(100)};
  const GovernorConfig g = for_request(base, spec);
  EXPECT_EQ(g.decision_period, 5u);
  ASSERT_TRUE(g.perception);
  EXPECT_EQ(g.perception->max_age_steps, 7u);
  EXPECT_EQ(g.perception->wait, std::chrono::milliseconds(100));
  spec.grounding = "state";
  EXPECT_FALSE(for_request(base, spec).perception);
  spec.grounding = "camera";
  EXPECT_THROW(for_request(base, spec), ConfigError);
  spec.grounding.reset();
  spec.decision_period = 0;
  EXPECT_THROW(for_request(base, spec), ConfigError) << "a decision period of 0";
  spec.decision_period.reset();
  base.perception = PerceptionLimits{};
  try {
    for_request(base, spec);
    FAIL() << "a perception arm without the request saying so was taken";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("grounding: perception"), std::string::npos) << e.what();
  }
}

TEST(GovernorPorts, MatchTheServiceReadme) {
  const char* home = std::getenv("DH_HOME");
  ASSERT_TRUE(home) << "DH_HOME names the checkout";
  EXPECT_EQ(port_table(std::filesystem::path(home) / "services/governor/README.md"), port_table(dh::gov::ports()));
}
