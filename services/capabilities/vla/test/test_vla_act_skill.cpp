// The vla_act skill around a scripted action source: chunk execution, temporal ensembling, waiting for a
// source that is not ready, a failing source, actions clamped.
#include <gtest/gtest.h>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/vla_act.hpp"

namespace dh::cap {
namespace {

// Chunk k (0-based) holds actions whose x component is 10·k + i (i = index in the chunk), scaled to fit.
class ScriptedSource : public ActionSource {
 public:
  int calls = 0, not_ready = 0;
  bool fail = false;
  double last_gripper = 0;
  std::vector<policy::Action> chunk(const Observation&, const std::string& instruction, double gripper) override {
    last_gripper = gripper;
    if (not_ready > 0) {
      --not_ready;
      throw SourceNotReady("no image yet");
    }
    if (fail) throw std::runtime_error("server gone");
    EXPECT_EQ(instruction, "put the bowl on the plate");
    std::vector<policy::Action> c(10);
    for (int i = 0; i < 10; ++i) c[i] = {0.01 * (10 * calls + i), 0, 0, 0, 0, 0, calls % 2 ? 1.0 : -1.0};
    ++calls;
    return c;
  }
  std::string describe() const override { return "scripted"; }
};

const Bindings kArgs{{"instruction", "put the bowl on the plate"}};

/// The library's θ (configs/library/vla_act.yaml) with `changed` over it.
Theta library_theta(const Theta& changed) {
  Theta t = load_descriptor(default_descriptor_file("vla_act"), vla_act_def(std::make_shared<ScriptedSource>())).parameters;
  for (const auto& [k, v] : changed) t[k] = v;
  return t;
}

TEST(VlaActSkill, ExecutesPartOfEachChunkThenAsksAgain) {
  auto src = std::make_shared<ScriptedSource>();
  VlaActSkill skill(src, library_theta({{"execute_steps", 3}}));
  Observation obs;
  EXPECT_TRUE(skill.check({}, obs, 100).has_value()) << "an instruction is required";
  ASSERT_FALSE(skill.check(kArgs, obs, 100));
  skill.start(kArgs, obs, {});
  std::vector<double> xs;
  double progress = 0;
  for (int t = 0; t < 7; ++t) {
    const SkillStep s = skill.next(obs);
    ASSERT_EQ(s.status, SkillStatus::Running);
    EXPECT_GT(s.progress, progress) << "progress always grows";
    progress = s.progress;
    xs.push_back(s.action[0]);
  }
  EXPECT_EQ(src->calls, 3);
  const std::vector<double> want{0.0, 0.01, 0.02, 0.1, 0.11, 0.12, 0.2};
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(xs[i], want[i], 1e-12) << i;
  EXPECT_DOUBLE_EQ(src->last_gripper, 1.0) << "the source is told the gripper action applied last";
}

TEST(VlaActSkill, EnsemblingAveragesTheChunksPredictionsForTheStep) {
  auto src = std::make_shared<ScriptedSource>();
  VlaActSkill skill(src, library_theta({{"ensemble_decay", 1e-9}}));  // equal weights
  Observation obs;
  skill.start(kArgs, obs, {});
  skill.next(obs);                        // chunk 0, its step 0: 0.00
  const SkillStep s = skill.next(obs);    // chunk 0 step 1 (0.01) and chunk 1 step 0 (0.10)
  EXPECT_NEAR(s.action[0], 0.055, 1e-9);
  EXPECT_EQ(src->calls, 2) << "asked every step";
}

TEST(VlaActSkill, HoldsStillWhileTheSourceIsNotReadyAndFailsWhenItStaysSo) {
  auto src = std::make_shared<ScriptedSource>();
  src->not_ready = 2;
  VlaActSkill skill(src, library_theta({{"max_wait_steps", 3}}));
  Observation obs;
  skill.start(kArgs, obs, {});
  for (int t = 0; t < 2; ++t) {
    const SkillStep s = skill.next(obs);
    EXPECT_EQ(s.status, SkillStatus::Running);
    EXPECT_EQ(s.stage, "wait");
    EXPECT_EQ(s.action, (policy::Action{0, 0, 0, 0, 0, 0, -1})) << "still, jaw as it was (open)";
  }
  EXPECT_EQ(skill.next(obs).stage, "act");
  src->not_ready = 10;
  skill.start(kArgs, obs, {});
  SkillStep s;
  for (int t = 0; t < 4; ++t) s = skill.next(obs);
  EXPECT_EQ(s.status, SkillStatus::Failed);
  EXPECT_NE(s.reason.find("no image yet"), std::string::npos) << s.reason;
}

TEST(VlaActSkill, AFailingSourceFailsTheCommandWithItsReasonAndActionsAreClamped) {
  auto src = std::make_shared<ScriptedSource>();
  src->calls = 500;  // x = 10·500 / 100 = 50: far out of range
  VlaActSkill skill(src, library_theta({}));
  Observation obs;
  skill.start(kArgs, obs, {});
  EXPECT_DOUBLE_EQ(skill.next(obs).action[0], 1.0);
  src->fail = true;
  skill.start(kArgs, obs, {});
  const SkillStep s = skill.next(obs);
  EXPECT_EQ(s.status, SkillStatus::Failed);
  EXPECT_EQ(s.reason, "policy: server gone");
}

}  // namespace
}  // namespace dh::cap

namespace dh::cap {
TEST(VlaActSkill, AThetaWithoutEveryParameterIsRefusedNamingTheMissingOnes) {
  try {
    VlaActSkill skill(std::make_shared<ScriptedSource>(), {{"execute_steps", 3}});
    FAIL() << "a partial θ was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("lacks ensemble_decay, cost_steps, max_wait_steps"), std::string::npos) << e.what();
  }
}

TEST(VlaActSkill, ItsAnnouncedVersionNamesWhatItRuns) {
  const auto d = load_descriptor(default_descriptor_file("vla_act"), vla_act_def(std::make_shared<ScriptedSource>()));
  EXPECT_NE(d.version.find("(scripted)"), std::string::npos) << d.version << ": the source is recorded with each grounding";
}
}  // namespace dh::cap
