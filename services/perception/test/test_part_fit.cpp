// An articulated part's joint value from depth: the hw cell's drawer and the microwave's door, built from
// their descriptions and ray cast at known joint values, are fitted back; a part nobody can see is not seen;
// the part models place their grips and regions as the simulator does.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <memory>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/perception/part_fit.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/workcell.hpp"
#include "synthetic_scene.hpp"

namespace dh::perception {
namespace {

const PartModel& part(const std::vector<PartModel>& models, const std::string& name) {
  const auto it = std::find_if(models.begin(), models.end(), [&](const auto& m) { return m.name == name; });
  if (it == models.end()) throw std::runtime_error("no part " + name);
  return *it;
}

sim::SceneSpec scene_of(const std::string& cell, std::uint32_t task) {
  return sim::load_nominal_scene(find_task(load_suites(paths::config_dir()), cell, task));
}

/// The part at joint value `q` and its fixture's body as boxes about world z (slides and hinges about z).
std::vector<synth::Box> boxes_at(const PartModel& m, double q) {
  std::vector<synth::Box> out;
  const Eigen::Isometry3d w = m.world_from_part(q);
  const double turn = std::atan2(w.rotation()(1, 0), w.rotation()(0, 0));
  for (const auto& b : m.boxes) out.push_back({w * b.centre, turn + b.yaw, 2 * b.half, {220, 220, 215}});
  for (std::size_t i = 1; i < m.still.size(); ++i)  // still[0] is the table, which the caster draws itself
    out.push_back({m.still[i].centre, m.still[i].yaw, 2 * m.still[i].half, {220, 220, 215}});
  return out;
}

/// The front camera's view (configs/cameras.yaml): beside the robot's base, looking at the fixtures' fronts.
synth::Scene front_view() {
  synth::Scene s;
  s.world_from_camera = synth::look_at(Eigen::Vector3d(-0.45, -0.6, 0.65), Eigen::Vector3d(0.1, 0.0, 0.08));
  return s;
}

PartEstimate fit(const synth::Scene& s, const PartModel& m) { return fit_parts(synth::render(s).frame, {m}).at(0); }

TEST(PartFit, TheDrawersTravelComesBackFromDepthAcrossItsRange) {
  const auto models = articulated_parts(scene_of("hw", 3));
  const PartModel& drawer = part(models, "drawer_unit_drawer");
  for (double q : {0.0, 0.05, 0.12, 0.16}) {
    synth::Scene s = front_view();
    s.boxes = boxes_at(drawer, q);
    const PartEstimate e = fit(s, drawer);
    EXPECT_NEAR(e.joint, q, 0.003) << "travel " << q;
    EXPECT_GT(e.confidence, 0.5) << "travel " << q;
    EXPECT_GE(e.support, 20u);
    // The regions ride on the drawer: its inside comes out with it.
    const auto region = std::find_if(e.riders.begin(), e.riders.end(),
                                     [](const auto& r) { return r.first == "drawer_unit_drawer_region"; });
    ASSERT_NE(region, e.riders.end());
    EXPECT_NEAR(region->second.x(), 0.12 - e.joint, 1e-9) << "the unit stands at x 0.12, the drawer slides along -x";
  }
}

TEST(PartFit, TheMicrowavesDoorAngleComesBackFromDepth) {
  const auto models = articulated_parts(scene_of("long", 9));
  const PartModel& door = part(models, "microwave_door");
  ASSERT_EQ(door.joint, PartModel::Joint::Hinge);
  for (double q : {0.0, -0.6, -1.6}) {
    synth::Scene s = front_view();
    s.boxes = boxes_at(door, q);
    const PartEstimate e = fit(s, door);
    EXPECT_NEAR(e.joint, q, 0.03) << "angle " << q;
    EXPECT_GT(e.confidence, 0.5) << "angle " << q;
  }
}

TEST(PartFit, APartBehindAWallIsNotSeenRatherThanGuessed) {
  const auto models = articulated_parts(scene_of("hw", 3));
  const PartModel& drawer = part(models, "drawer_unit_drawer");
  synth::Scene s = front_view();
  s.boxes = boxes_at(drawer, 0.1);
  // A board between the camera and the unit hides it whole.
  s.boxes.push_back({Eigen::Vector3d(-0.2, 0.0, 0.2), 0.6, Eigen::Vector3d(0.02, 1.2, 0.4), {90, 90, 90}});
  const PartEstimate e = fit(s, drawer);
  EXPECT_EQ(e.confidence, 0) << "fitted " << e.joint << " on " << e.support << " points";
}

TEST(PartFit, ThePartModelsPlaceGripsAndRegionsAsTheSimulatorDoes) {
  // Every scene with parts: each part's grip and regions at two joint values, against MuJoCo's kinematics.
  for (const auto& [cell, task] : std::vector<std::pair<std::string, std::uint32_t>>{{"goal", 0}, {"long", 9}, {"hw", 3}, {"long", 8}, {"long", 3}}) {
    const sim::SceneSpec spec = scene_of(cell, task);
    const auto models = articulated_parts(spec);
    ASSERT_FALSE(models.empty()) << cell << " " << task;
    sim::Workcell cell_sim(spec);
    cell_sim.reset(1, {});
    const mjModel* m = cell_sim.model();
    std::unique_ptr<mjData, void (*)(mjData*)> d(mj_copyData(nullptr, m, cell_sim.data()), mj_deleteData);
    for (const double share : {0.3, 0.9}) {
      std::map<std::string, double> q;
      for (const auto& p : models) {
        q[p.name] = p.lo + share * (p.hi - p.lo);
        d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, (p.name + "_joint").c_str())]] = q[p.name];
      }
      mj_forward(m, d.get());
      for (const auto& p : models) {
        const Eigen::Isometry3d w = p.world_from_part(q[p.name]);
        for (const auto& r : p.riders) {
          const std::string site = r.name == p.name ? p.name + "_grip" : r.name;
          const int id = mj_name2id(m, mjOBJ_SITE, site.c_str());
          ASSERT_GE(id, 0) << site;
          const Eigen::Vector3d truth(d->site_xpos[3 * id], d->site_xpos[3 * id + 1], d->site_xpos[3 * id + 2]);
          EXPECT_LT((w * r.pos - truth).norm(), 1e-9) << cell << " " << site << " at " << q[p.name];
        }
      }
    }
  }
}

}  // namespace
}  // namespace dh::perception
