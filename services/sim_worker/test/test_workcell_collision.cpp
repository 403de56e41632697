// Every arm link collides (docs/controller.md): a wrist coming down on a block stops there, while the
// same motion without the block takes the tool down to the table.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "config_files.hpp"  // tests/support
#include "dh/common/paths.hpp"
#include "dh/common/robot_contract.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

// A block 30 cm high across the table in front of the robot, and a scene with or without it.
std::filesystem::path beam_scene(const test::TempDir& t, bool with_beam, const std::string& controller) {
  t.write("assets/beam.yaml",
          "asset: beam\nkind: beam\nfixture: true\nrgba: [0.5, 0.5, 0.5, 1]\n"
          "geoms:\n  - {type: box, size: [0.115, 0.3, 0.15], pos: [0, 0, 0.15]}\n");
  std::string scene = "scene: beam\ntable:\n  size: [1.0, 1.2, 0.05]\nrobot:\n  profile: " +
                      (paths::config_dir() / "robots/panda.yaml").string() +
                      "\n  controller: " + controller + "\n  base: [-0.56, 0.0, 0.0]\n"
                      "workspace:\n  min: [-0.45, -0.5, -0.005]\n  max: [0.45, 0.5, 0.6]\n";
  scene += with_beam ? "entities:\n  - {name: beam, asset: beam, xy: [-0.135, 0.0]}\n" : "entities: []\n";
  return t.write("scenes/" + controller + (with_beam ? "_beam.yaml" : "_open.yaml"), scene);
}

struct Descent {
  double lowest_tool_z = 1;
  std::set<std::string> links_on_beam;  ///< arm links (not hand, not fingers) in contact with the block
};

// The tool goes top-down to 0.55 m above x = 0.06, just past the block's front, then is driven down
// towards the table: the hand clears the block, the wrist above it does not.
Descent descend(sim::Workcell& cell) {
  cell.reset(0, {});
  const mjModel* m = cell.model();
  const mjData* d = cell.data();
  const int beam = mj_name2id(m, mjOBJ_BODY, "beam");
  Descent out;
  auto drive = [&](const std::array<double, 3>& to, int steps) {
    for (int k = 0; k < steps; ++k) {
      const Observation o = cell.observe();
      std::array<double, 7> a{};
      for (int i = 0; i < 3; ++i) a[i] = std::clamp((to[i] - o.ee_p[i]) / 0.05 * 3, -1.0, 1.0);
      a[6] = -1;
      cell.step(a);
      for (int c = 0; c < d->ncon; ++c) {
        const int b1 = m->geom_bodyid[d->contact[c].geom1], b2 = m->geom_bodyid[d->contact[c].geom2];
        const int other = b1 == beam ? b2 : b2 == beam ? b1 : -1;
        if (beam >= 0 && other >= 0) {
          const std::string name = mj_id2name(m, mjOBJ_BODY, other);
          if (name.rfind("link", 0) == 0) out.links_on_beam.insert(name);
        }
      }
    }
  };
  drive({0.06, 0.0, 0.55}, 60);
  drive({0.06, 0.0, 0.05}, 80);
  out.lowest_tool_z = cell.observe().ee_p[2];
  return out;
}

TEST(WorkcellCollision, AWristComingDownOnABlockStopsThere) {
  test::TempDir t;
  for (const std::string controller : {"joint_ik", "osc_pose"}) {
    SCOPED_TRACE(controller);
    sim::Workcell free_cell(sim::load_scene(beam_scene(t, false, controller)));
    const Descent free = descend(free_cell);
    EXPECT_LT(free.lowest_tool_z, 0.1) << "without the block the tool reaches down towards the table";
    sim::Workcell blocked_cell(sim::load_scene(beam_scene(t, true, controller)));
    const Descent blocked = descend(blocked_cell);
    EXPECT_FALSE(blocked.links_on_beam.empty()) << "an arm link other than the hand touches the block";
    EXPECT_GT(blocked.lowest_tool_z, free.lowest_tool_z + 0.05) << "the block holds the arm up";
    EXPECT_LT(blocked_cell.max_penetration(), 0.01) << "and the link rests on it, not in it";
    for (const auto& l : blocked.links_on_beam) std::cout << controller << ", on the block: " << l << "\n";
    std::cout << controller << ", tool z: " << free.lowest_tool_z << " without the block, " << blocked.lowest_tool_z
              << " with it\n";
  }
}

// OSC_POSE's meaning of an action: under a constant a the tool settles where it covers the contract's share
// of the goal's offset each step, robot::kOscStepShare (0.265 m/s at |a| = 1; kp * 0.05 m * a / kd, 0.31 m/s,
// would hold were the goal not rebased on the tool every step). The skills' feed-forward rests on it.
TEST(OscPose, TheToolSettlesAtTheContractsStepShare) {
  test::TempDir t;
  sim::Workcell cell(sim::load_scene(beam_scene(t, false, "osc_pose")));
  cell.reset(0, {});
  for (int k = 0; k < 12; ++k) cell.step({0, 0.5, 0, 0, 0, 0, -1});
  const double y0 = cell.observe().ee_p[1];
  for (int k = 0; k < 4; ++k) cell.step({0, 0.5, 0, 0, 0, 0, -1});
  const double speed = (cell.observe().ee_p[1] - y0) / (4 * robot::kControlPeriodS);
  const double law = robot::kOscStepShare * robot::kMaxDeltaPosM * 0.5 / robot::kControlPeriodS;
  EXPECT_GT(speed, 0.95 * law);
  EXPECT_LT(speed, 1.05 * law);
}

}  // namespace
}  // namespace dh
