// The test controller's arm on a benchmark scene's mount, as the cell's dry run stands it: the arm where
// the scene mounts it, the scene's entities where the seed places them, and the adapter's world the
// scene's world.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/rtde/oracle_verdict.hpp"
#include "dh/rtde/rtde_cell.hpp"
#include "dh/rtde/simulated_ur.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::rtde {
namespace {

sim::SceneSpec goal_scene(std::uint64_t seed) {
  static const auto suites = load_suites(paths::config_dir());
  return sim::load_task_scene(find_task(suites, "goal", 1), seed, "ur7e");
}

std::array<double, 3> world_tcp(SimulatedUr& arm) {
  const int t = mj_name2id(arm.mj_model(), mjOBJ_SITE, "tcp");
  const double* p = arm.mj_data()->site_xpos + 3 * t;
  return {p[0], p[1], p[2]};
}

TEST(SceneArm, StandsOnTheScenesMountAmongTheEntitiesTheSeedPlaces) {
  const sim::SceneSpec scene = goal_scene(21);
  SimulatedUr arm(scene, 21);
  EXPECT_EQ(arm.base(), scene.robot_base);
  const auto q = std::get<std::array<double, 6>>(arm.output("actual_q"));
  for (int i = 0; i < 6; ++i) EXPECT_EQ(q[i], scene.ready_q[i]) << "joint " << i;
  // The controller reports the tool in its base frame; the world is the scene's.
  const auto tool = std::get<std::array<double, 6>>(arm.output("actual_TCP_pose"));
  const auto world = world_tcp(arm);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(tool[i] + scene.robot_base[i], world[i], 1e-12);
  // Where the benchmark's workcell holds the same arm on the same scene (after its 0.4 s settling).
  sim::Workcell cell(scene);
  cell.reset(21, {});
  const Observation o = cell.observe();
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(world[i], o.ee_p[i], 0.005) << "axis " << i;
  // Free objects where the seed places them, fixtures and their parts where the workcell has them.
  const auto placements = sim::sample_placements(scene, 21);
  int objects = 0;
  for (std::size_t k = 0; k < scene.entities.size(); ++k) {
    const auto& e = scene.entities[k];
    const double* p = arm.mj_data()->xpos + 3 * mj_name2id(arm.mj_model(), mjOBJ_BODY, e.name.c_str());
    if (e.fixture()) {
      const auto seen =
          std::find_if(o.entities.begin(), o.entities.end(), [&](const auto& s) { return s.name == e.name; });
      ASSERT_NE(seen, o.entities.end()) << e.name;
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(p[i], seen->p[i], 1e-9) << e.name;
      continue;
    }
    ++objects;
    EXPECT_EQ(p[0], placements[k].x) << e.name;
    EXPECT_EQ(p[1], placements[k].y) << e.name;
  }
  EXPECT_GT(objects, 2);
}

TEST(SceneArm, TheAdapterMovesTheToolInTheScenesWorld) {
  const sim::SceneSpec scene = goal_scene(22);
  SimulatedController controller(scene, 22);
  RtdeCellConfig c;
  c.rtde_port = controller.port();
  c.script_port = controller.script_port();
  c.base_xyz = scene.robot_base;
  RtdeCell cell(c);
  cell.connect();
  const Observation start = cell.observe();
  const auto world = controller.with_arm([](SimulatedUr& a) { return world_tcp(a); });
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(start.ee_p[i], world[i], 0.001) << "axis " << i;
  for (int i = 0; i < 10; ++i) {
    const auto events = cell.step({0, 0.5, 0, 0, 0, 0, -1});
    EXPECT_TRUE(events.empty()) << events.front().reason;
  }
  const Observation end = cell.observe();
  // As far as on the arm alone (test_rtde_cell.cpp): 10 steps at 0.5 of 0.0133 m per step.
  EXPECT_NEAR(end.ee_p[1] - start.ee_p[1], 10 * 0.5 * 0.05 * 0.2655, 0.02);
  EXPECT_NEAR(end.ee_p[0], start.ee_p[0], 0.01);
  EXPECT_NEAR(end.ee_p[2], start.ee_p[2], 0.01);
}

TEST(SceneArm, AnArmOfAnotherJointCountIsRefusedNamingIt) {
  static const auto suites = load_suites(paths::config_dir());
  const sim::SceneSpec panda = sim::load_task_scene(find_task(suites, "goal", 1), 21);
  try {
    SimulatedUr arm(panda, 21);
    FAIL() << "a 7-joint arm was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs a 6-joint arm, found 7"), std::string::npos) << e.what();
  }
}

TEST(SceneArm, TheOracleSaysWhetherTheGoalHoldsInTheArmsWorld) {
  static const auto suites = load_suites(paths::config_dir());
  const TaskDef& task = find_task(suites, "hw", 0);  // the ring over the post
  const sim::SceneSpec scene = sim::load_task_scene(task, 3, "ur7e");
  SimulatedUr arm(scene, 3);
  const auto file = std::filesystem::path(testing::TempDir()) / "oracle.json";
  OracleVerdict oracle(arm, scene, task, file);
  EXPECT_TRUE(oracle.judge(arm)) << "the first judgement is news";
  EXPECT_FALSE(oracle.holds());
  EXPECT_FALSE(oracle.judge(arm)) << "nothing changed";
  // The ring moved down around the post's foot.
  mjData* d = arm.mj_data();
  const int q = arm.mj_model()->jnt_qposadr[arm.mj_model()->body_jntadr[mj_name2id(arm.mj_model(), mjOBJ_BODY, "ring")]];
  d->qpos[q] = 0.0, d->qpos[q + 1] = -0.3, d->qpos[q + 2] = 0.007;
  mj_forward(arm.mj_model(), d);
  EXPECT_TRUE(oracle.judge(arm));
  EXPECT_TRUE(oracle.holds());
  oracle.write();
  const auto j = nlohmann::json::parse(std::ifstream(file));
  EXPECT_TRUE(j["holds"].get<bool>());
  EXPECT_EQ(j["goal"], "In(ring, post_around_region)");
  // A goal naming what the scene lacks is refused with the term.
  TaskDef wrong = task;
  wrong.goal = {{"In", {"ring", "toaster_middle_slot"}}};
  try {
    OracleVerdict bad(arm, scene, wrong, file);
    ADD_FAILURE() << "a goal naming a missing region was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("toaster_middle_slot"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dh::rtde
