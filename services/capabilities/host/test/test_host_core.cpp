// The capability host core without DDS or physics: a scripted skill shows what the core does with each
// event — when a command is grounded and started, that each step is answered once, the budget, the
// keyframes, superseding, cancelling and draining.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "dh/cap/host_core.hpp"

using namespace dh;
using namespace dh::cap;

namespace {

/// Moves +x for `steps` steps, then completes; refuses an argument named "refuse".
class Scripted : public Skill {
 public:
  explicit Scripted(const Theta& theta)
      : steps_(static_cast<int>(theta.count("steps") ? theta.at("steps") : 5)) {
    for (const auto& [k, v] : theta)
      if (k != "steps") throw std::invalid_argument("unknown parameter '" + k + "'");
  }
  std::optional<std::string> check(const Bindings& args, const Observation&, int budget) const override {
    if (arg(args, "object") == "refuse") return "scripted refusal";
    if (budget < 1) return "no budget";
    return std::nullopt;
  }
  void start(const Bindings&, const Observation&, const SkillContext& ctx) override {
    keyframes_seen = ctx.keyframes.size();
  }
  SkillStep next(const Observation&) override {
    if (done_ == steps_) return completed_step();
    SkillStep s;
    s.action[0] = 1;
    s.stage = done_ < 2 ? "approach" : "move";
    s.progress = double(++done_) / steps_;
    return s;
  }
  int cost_steps() const override { return steps_; }
  static inline std::size_t keyframes_seen = 0;

 private:
  int steps_, done_ = 0;
};

CapabilityDef scripted() {
  return {"scripted", [](const Theta& t) -> std::unique_ptr<Skill> { return std::make_unique<Scripted>(t); }};
}

Observation obs(std::uint32_t step, const std::string& episode = "e1", bool holding = false) {
  Observation o;
  o.channel = 3;
  o.episode_id = episode;
  o.step = step;
  o.ee_p = {0.1 * step, 0, 0.5};
  o.contact_left = o.contact_right = holding;
  o.gripper_opening = 0.03;
  return o;
}

CommandStart start(const std::string& id, std::uint32_t at, std::uint32_t budget = 20, Theta theta = {}) {
  CommandStart c;
  c.channel = 3;
  c.episode_id = "e1";
  c.command_id = id;
  c.capability = "scripted";
  c.instance = "scripted@test";
  c.args = {{"object", "bowl"}};
  c.theta = std::move(theta);
  c.start_step = at;
  c.budget_steps = budget;
  c.decision_period = 10;
  return c;
}

const Clock::time_point t0{};

struct HostCoreTest : ::testing::Test {
  HostCore core{std::vector<ServedCapability>{{scripted(), "scripted@test"}}};
};

}  // namespace

TEST_F(HostCoreTest, StartsOnTheStartStepsObservationAndAnswersEachStepOnce) {
  core.on_observation(obs(4), t0);
  // The command is for step 5: the observation of step 4 does not start it.
  auto fx = core.on_start(start("c1", 5), t0);
  EXPECT_TRUE(fx.statuses.empty());
  EXPECT_TRUE(fx.actions.empty());
  fx = core.on_observation(obs(5), t0);
  ASSERT_EQ(fx.statuses.size(), 2u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Accepted);
  EXPECT_EQ(fx.statuses[1].state, CommandState::Running);  // the first stage is reported
  ASSERT_EQ(fx.actions.size(), 1u);
  EXPECT_EQ(fx.actions[0].step, 5u);
  EXPECT_EQ(fx.actions[0].episode_id, "e1");
  // The same step again (a redelivery) is not answered twice.
  EXPECT_TRUE(core.on_observation(obs(5), t0).actions.empty());
  EXPECT_EQ(core.on_observation(obs(6), t0).actions.size(), 1u);
}

TEST_F(HostCoreTest, ACommandAfterItsObservationStartsAtOnce) {
  core.on_observation(obs(0), t0);
  const auto fx = core.on_start(start("c1", 0), t0);
  ASSERT_FALSE(fx.statuses.empty());
  EXPECT_EQ(fx.statuses[0].state, CommandState::Accepted);
  EXPECT_EQ(fx.actions.size(), 1u);
}

TEST_F(HostCoreTest, CompletesAndReportsProgressAtStageChangesAndDecisionSteps) {
  core.on_observation(obs(0), t0);
  core.on_start(start("c1", 0, 20, {{"steps", 12}}), t0);
  std::vector<std::uint32_t> running_at;
  for (std::uint32_t s = 1; s <= 12; ++s) {
    const auto fx = core.on_observation(obs(s), t0);
    for (const auto& st : fx.statuses)
      if (st.state == CommandState::Running) running_at.push_back(st.step);
    if (s == 12) {
      ASSERT_EQ(fx.statuses.size(), 1u);
      EXPECT_EQ(fx.statuses[0].state, CommandState::Completed);
      EXPECT_EQ(fx.statuses[0].steps_used, 12u);
      EXPECT_TRUE(fx.actions.empty());
    }
  }
  EXPECT_EQ(running_at, (std::vector<std::uint32_t>{2, 10}));  // "move" from step 2; decision step 10
  EXPECT_EQ(core.running(), 0u);
}

TEST_F(HostCoreTest, SpendsNoMoreThanTheCommandBudget) {
  core.on_observation(obs(0), t0);
  auto fx = core.on_start(start("c1", 0, 3, {{"steps", 50}}), t0);
  int actions = static_cast<int>(fx.actions.size());
  for (std::uint32_t s = 1; s <= 3; ++s) {
    fx = core.on_observation(obs(s), t0);
    actions += static_cast<int>(fx.actions.size());
  }
  EXPECT_EQ(actions, 3);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Expired);
  EXPECT_NE(fx.statuses[0].reason.find("budget of 3"), std::string::npos);
}

TEST_F(HostCoreTest, ALeaseRaisesTheBudgetOfItsOwnCommandOnly) {
  core.on_observation(obs(0), t0);
  auto fx = core.on_start(start("c1", 0, 3, {{"steps", 50}}), t0);
  int actions = static_cast<int>(fx.actions.size());
  core.on_lease(3, "e1", "c0", 20);  // another command's
  core.on_lease(3, "e2", "c1", 20);  // another episode's
  core.on_lease(4, "e1", "c1", 20);  // another channel's
  core.on_lease(3, "e1", "c1", 6);
  core.on_lease(3, "e1", "c1", 4);  // an older lease does not lower it again
  for (std::uint32_t s = 1; s <= 6; ++s) {
    fx = core.on_observation(obs(s), t0);
    actions += static_cast<int>(fx.actions.size());
  }
  EXPECT_EQ(actions, 6);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Expired);
  EXPECT_NE(fx.statuses[0].reason.find("budget of 6"), std::string::npos) << fx.statuses[0].reason;
}

TEST_F(HostCoreTest, RefusesAtItsCheckAndAMalformedTheta) {
  core.on_observation(obs(0), t0);
  auto c = start("c1", 0);
  c.args = {{"object", "refuse"}};
  auto fx = core.on_start(c, t0);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Refused);
  EXPECT_EQ(fx.statuses[0].reason, "scripted refusal");
  fx = core.on_start(start("c2", 0, 20, {{"wobble", 1}}), t0);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Refused);
  EXPECT_NE(fx.statuses[0].reason.find("malformed command: unknown parameter 'wobble'"), std::string::npos);
  EXPECT_EQ(core.running(), 0u);
}

TEST_F(HostCoreTest, ANewerCommandSupersedesAndACancelNeedsTheRunningId) {
  core.on_observation(obs(0), t0);
  core.on_start(start("c1", 0), t0);
  auto cancel_other = core.on_cancel({3, "e1", "c0", "scripted@test"});
  EXPECT_TRUE(cancel_other.statuses.empty());
  core.on_observation(obs(1), t0);
  // A START for another process's instance still supersedes here: the governor moved on.
  auto other = start("c2", 1);
  other.instance = "push@elsewhere";
  auto fx = core.on_start(other, t0);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Cancelled);
  EXPECT_EQ(fx.statuses[0].reason, "superseded by c2");
  EXPECT_EQ(core.running(), 0u);
  core.on_start(start("c3", 1), t0);
  fx = core.on_cancel({3, "e1", "c3", "scripted@test"});
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].reason, "cancelled by the governor");
}

TEST_F(HostCoreTest, KeyframesAreEmptyHandedCommandStartsOfTheEpisode) {
  core.on_observation(obs(0), t0);
  core.on_start(start("c1", 0, 20, {{"steps", 1}}), t0);
  core.on_observation(obs(1), t0);  // c1 completes
  core.on_observation(obs(2, "e1", true), t0);
  core.on_start(start("c2", 2, 20, {{"steps", 1}}), t0);  // holding: no keyframe
  EXPECT_EQ(Scripted::keyframes_seen, 1u);
  core.on_observation(obs(3), t0);
  core.on_start(start("c3", 3), t0);
  EXPECT_EQ(Scripted::keyframes_seen, 2u);
  ASSERT_EQ(core.keyframes(3).size(), 2u);
  EXPECT_EQ(core.keyframes(3)[1].step, 3u);
  core.on_observation(obs(0, "e2"), t0);  // a new episode on the channel
  EXPECT_TRUE(core.keyframes(3).empty());
}

// The command and its start step's observation come on two topics: either order leaves the start
// step's pose, once (over DDS and in process alike).
TEST_F(HostCoreTest, AKeyframeIsTheStartStepsPoseWhicheverComesFirst) {
  core.on_observation(obs(4), t0);
  core.on_start(start("c1", 5, 20, {{"steps", 1}}), t0);  // before step 5's observation
  EXPECT_TRUE(core.keyframes(3).empty());
  core.on_observation(obs(5), t0);
  ASSERT_EQ(core.keyframes(3).size(), 1u);
  EXPECT_EQ(core.keyframes(3)[0].step, 5u);
  EXPECT_DOUBLE_EQ(core.keyframes(3)[0].p[0], 0.5);
  core.on_observation(obs(6), t0);  // c1 completes
  core.on_start(start("c2", 6, 20, {{"object", 0}}), t0);  // refused by θ, after its observation
  core.on_start(start("c3", 6), t0);                      // the next one on the same step
  ASSERT_EQ(core.keyframes(3).size(), 2u);
  EXPECT_EQ(core.keyframes(3)[1].step, 6u);
}

// Over DDS a host is sent only the steps of its own commands and every command's start step, said again to
// every host when the command's first lease reaches the seam (processes.md, "Who gets an observation"): it
// starts on the start step said again, keeps the episode's keyframes from the starts, and answers a step
// once however often it comes.
TEST_F(HostCoreTest, WithOnlyItsOwnStepsAndEveryStartSaidAgainItActsOnceAndKeepsTheKeyframes) {
  core.on_observation(obs(0), t0);  // step 0 is for everyone
  CommandStart other = start("other", 0);
  other.instance = "scripted@another-host";
  EXPECT_TRUE(core.on_start(other, t0).actions.empty());  // another host's command: a keyframe at step 0
  // Steps 1-6 went to the other host. The next command starts on step 7, which this host has not had.
  auto fx = core.on_start(start("c1", 7, 20, {{"steps", 2}}), t0);
  EXPECT_TRUE(fx.actions.empty());
  fx = core.on_observation(obs(7), t0);  // step 7 said again
  ASSERT_EQ(fx.actions.size(), 1u);
  EXPECT_EQ(fx.actions[0].step, 7u);
  EXPECT_EQ(Scripted::keyframes_seen, 2u) << "the starts at steps 0 and 7";
  EXPECT_TRUE(core.on_observation(obs(7), t0).actions.empty()) << "the start said again after it was sent";
  EXPECT_EQ(core.on_observation(obs(8), t0).actions.size(), 1u);
}

TEST_F(HostCoreTest, ADrainingCoreRefusesNewCommandsAndFinishesRunningOnes) {
  core.on_observation(obs(0), t0);
  core.on_start(start("c1", 0, 20, {{"steps", 2}}), t0);
  core.drain();
  EXPECT_EQ(core.on_observation(obs(1), t0).actions.size(), 1u);
  auto other = start("c2", 1);
  other.channel = 4;
  const auto fx = core.on_start(other, t0);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Refused);
  EXPECT_NE(fx.statuses[0].reason.find("draining"), std::string::npos);
  EXPECT_EQ(core.on_observation(obs(2), t0).statuses.at(0).state, CommandState::Completed);
}

TEST_F(HostCoreTest, PerceivedCommandsWaitForAFrameThenRefuse) {
  core.on_observation(obs(0), t0);
  auto c = start("c1", 0);
  c.grounding = Grounding::Perception;
  EXPECT_TRUE(core.on_start(c, t0).statuses.empty());  // waiting for a scene estimate, not acting
  EXPECT_TRUE(core.on_tick(t0 + PerceptionLimits{}.wait / 2).statuses.empty());
  const auto fx = core.on_tick(t0 + PerceptionLimits{}.wait);
  ASSERT_EQ(fx.statuses.size(), 1u);
  EXPECT_EQ(fx.statuses[0].state, CommandState::Refused);
  EXPECT_NE(fx.statuses[0].reason.find("no scene estimate"), std::string::npos) << fx.statuses[0].reason;
}

TEST_F(HostCoreTest, DeclaresItsPorts) {
  std::set<std::string> in, out;
  for (const auto& p : HostCore::ports()) (p.direction == PortDirection::In ? in : out).insert(std::string(p.topic));
  EXPECT_EQ(in, (std::set<std::string>{"rt/dh/command", "rt/dh/observation", "rt/dh/perception/scene",
                                       "rt/dh/lease"}));
  EXPECT_EQ(out, (std::set<std::string>{"rt/dh/action", "rt/dh/command/status", "rt/dh/capability/announce"}));
}

TEST(HostCorePorts, MatchTheServiceReadme) {
  const char* home = std::getenv("DH_HOME");
  ASSERT_TRUE(home) << "DH_HOME names the checkout";
  EXPECT_EQ(port_table(std::filesystem::path(home) / "services/capabilities/README.md"), port_table(HostCore::ports()));
}
