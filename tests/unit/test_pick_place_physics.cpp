// pick_place against real MuJoCo physics in one process: the grasp is physical (friction, no weld).
#include <gtest/gtest.h>

#include "inprocess_episode.hpp"

using namespace dh;

namespace {
struct PickPlacePhysics : ::testing::Test {
  static void SetUpTestSuite() {
    suites = new std::map<std::string, SuiteDef>(load_suites(paths::config_dir()));
    cell = new sim::Workcell(sim::load_scene(find_task(*suites, "goal", 8).scene_file));
  }
  static void TearDownTestSuite() {
    delete cell;
    delete suites;
  }
  static std::map<std::string, SuiteDef>* suites;
  static sim::Workcell* cell;
};
std::map<std::string, SuiteDef>* PickPlacePhysics::suites = nullptr;
sim::Workcell* PickPlacePhysics::cell = nullptr;
}  // namespace

TEST_F(PickPlacePhysics, BowlOnPlateSucceedsOnAtLeast18OfSeeds1To20) {
  const TaskDef& task = find_task(*suites, "goal", 8);
  int ok = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    const auto r = test::run_pick_place(*cell, task, seed, "bowl", "plate");
    ok += r.success;
    EXPECT_EQ(r.safety_events, 0) << "seed " << seed;
    if (!r.success) ADD_FAILURE() << "seed " << seed << " failed at " << r.stage << ": " << r.reason;
  }
  EXPECT_GE(ok, 18);
}

TEST_F(PickPlacePhysics, TheBowlRisesOnlyBecauseTheJawHoldsIt) {
  // Close on air next to the bowl: the skill must report a missed grasp, and the bowl stays down.
  const TaskDef& task = find_task(*suites, "goal", 8);
  cell->reset(3, task.goal);
  Observation obs = cell->observe();
  const double z0 = obs.entity("bowl")->p[2];
  cap::PickPlaceParams p;
  p.rim_grasp_depth = -0.05;  // a grasp point 5 cm above the rim
  cap::PickPlaceSkill skill(p);
  skill.start("bowl", "plate", obs);
  cap::SkillStep s;
  for (int t = 0; t < 300 && (s = skill.next(obs)).status == cap::SkillStatus::Running; ++t) {
    cell->step(s.action);
    obs = cell->observe();
  }
  EXPECT_EQ(s.status, cap::SkillStatus::Failed);
  EXPECT_NE(s.reason.find("grasp missed"), std::string::npos) << s.reason;
  EXPECT_NEAR(obs.entity("bowl")->p[2], z0, 0.005);
}

TEST_F(PickPlacePhysics, ASeedFixesTheInitialStateExactly) {
  const TaskDef& task = find_task(*suites, "goal", 8);
  cell->reset(7, task.goal);
  const auto a = cell->state();
  cell->reset(8, task.goal);
  EXPECT_NE(a, cell->state());
  cell->reset(7, task.goal);
  EXPECT_EQ(a, cell->state());
}

TEST_F(PickPlacePhysics, TheSkillRefusesWhatItCannotAfford) {
  cell->reset(1, find_task(*suites, "goal", 8).goal);
  cap::PickPlaceSkill skill{cap::PickPlaceParams{}};
  const auto why = skill.check("bowl", "plate", cell->observe(), 100);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("cannot pay"), std::string::npos);
  EXPECT_TRUE(skill.check("plate", "bowl", cell->observe(), 300)) << "a flat plate is not graspable";
}
