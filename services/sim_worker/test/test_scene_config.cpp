// Scene files: a bad robot, an unknown asset, a bad geom and a jittered fixture are named.
#include <gtest/gtest.h>

#include <filesystem>

#include "config_files.hpp"  // tests/support
#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/sim/scene.hpp"

using namespace dh;
namespace fs = std::filesystem;

using test::error_of;
using test::TempDir;

TEST(Scene, UnknownAssetBadGeomAndBadUrdfAreNamed) {
  TempDir t;
  const std::string head = "scene: s\ntable: {size: [1, 1, 0.05]}\nworkspace: {min: [0,0,0], max: [1,1,1]}\n";
  t.write("robots/bad.urdf", "<robot name='x'><link name='a'/></robot>");
  t.write("robots/bad.yaml", "urdf: bad.urdf\nready_q: [0,0,0,0,0,0,0]\n");
  auto f = t.write("scenes/s1.yaml", head + "robot: {profile: ../robots/bad.yaml, base: [0,0,0]}\nentities: []\n");
  auto e = error_of([&] { sim::load_scene(f); });
  EXPECT_NE(e.find("bad.urdf: expected 6 or 7 revolute arm joints"), std::string::npos) << e;
  const fs::path panda = paths::config_dir() / "robots" / "panda.yaml";
  const std::string robot = "robot: {profile: " + panda.string() + ", base: [0,0,0]}\n";
  f = t.write("scenes/s2.yaml", head + robot + "entities:\n  - {name: t, asset: teapot, xy: [0, 0]}\n");
  e = error_of([&] { sim::load_scene(f); });
  EXPECT_NE(e.find("key 'entities[0].asset': no asset 'teapot'"), std::string::npos) << e;
  t.write("assets/blob.yaml", "asset: blob\nkind: blob\nmass: 1\nrgba: [1,1,1,1]\ngeoms:\n  - {type: sphere, size: [1,1,1], pos: [0,0,0]}\n");
  f = t.write("scenes/s3.yaml", head + robot + "entities:\n  - {name: b, asset: blob, xy: [0, 0]}\n");
  e = error_of([&] { sim::load_scene(f); });
  EXPECT_NE(e.find("blob.yaml: key 'geoms[0].type': unknown geom type 'sphere'"), std::string::npos) << e;
  t.write("assets/shelf.yaml", "asset: shelf\nkind: shelf\nfixture: true\nrgba: [1,1,1,1]\ngeoms:\n  - {type: box, size: [0.1,0.1,0.1], pos: [0,0,0.1]}\n");
  f = t.write("scenes/s4.yaml", head + robot + "entities:\n  - {name: s, asset: shelf, xy: [0, 0], jitter: 0.1}\n");
  e = error_of([&] { sim::load_scene(f); });
  EXPECT_NE(e.find("key 'entities[0].jitter': fixtures stand where the scene puts them"), std::string::npos) << e;
}

TEST(Scene, ARobotProfileStandsOnTheScenesMountAndBadProfilesAreNamed) {
  const fs::path scene = paths::config_dir() / "scenes" / "kitchen_goal.yaml";
  const sim::SceneSpec panda = sim::load_scene(scene);
  EXPECT_EQ(panda.robot_profile, "panda");
  EXPECT_EQ(panda.ready_q.size(), 7u);
  const sim::SceneSpec ur = sim::load_scene(scene, sim::robot_profile("ur7e"));
  EXPECT_EQ(ur.robot_profile, "ur7e");
  EXPECT_EQ(ur.robot.arm.size(), 6u);
  EXPECT_EQ(ur.ready_q.size(), 6u);
  EXPECT_EQ(ur.robot_base, panda.robot_base);
  auto e = error_of([] { sim::robot_profile("kuka"); });
  EXPECT_NE(e.find("no robot 'kuka'"), std::string::npos) << e;
  EXPECT_NE(e.find("panda"), std::string::npos) << e;
  EXPECT_NE(e.find("ur7e"), std::string::npos) << e;

  TempDir t;
  const std::string urdf = (paths::config_dir() / "robots" / "ur7e.urdf").string();
  const auto short_q = t.write("robots/short.yaml", "urdf: " + urdf + "\nready_q: [0, 0, 0, 0, 0, 0, 0]\n");
  e = error_of([&] { sim::load_scene(scene, short_q); });
  EXPECT_NE(e.find("short.yaml: key 'ready_q': 7 values for the 6 arm joints"), std::string::npos) << e;
  const auto ik = t.write("scenes/ik.yaml", "scene: s\ntable: {size: [1, 1, 0.05]}\nworkspace: {min: [0,0,0], max: [1,1,1]}\n"
                                            "robot: {profile: " + (paths::config_dir() / "robots" / "ur7e.yaml").string() +
                                            ", base: [0,0,0], controller: joint_ik}\nentities: []\n");
  e = error_of([&] { sim::load_scene(ik); });
  EXPECT_NE(e.find("key 'robot.controller': joint_ik drives 7-joint arms"), std::string::npos) << e;
}
