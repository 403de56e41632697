// The UR7e model (configs/robots/ur7e.urdf) against UR's published kinematics: the MuJoCo model built
// from the URDF puts the flange where the standard DH chain (docs/ur7e-model.md) puts it, at any joint
// values, and the gripper's stroke is the 2F-85's.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <random>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/robot_model.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

// UR5e = UR7e, standard DH: a, d, alpha per joint.
constexpr double kA[6] = {0, -0.425, -0.3922, 0, 0, 0};
constexpr double kD[6] = {0.1625, 0, 0, 0.1333, 0.0997, 0.0996};
constexpr double kAlpha[6] = {M_PI / 2, 0, 0, M_PI / 2, -M_PI / 2, 0};

Eigen::Isometry3d dh_flange(const std::array<double, 6>& q) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i)
    t = t * Eigen::AngleAxisd(q[i], Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(kA[i], 0, kD[i]) *
        Eigen::AngleAxisd(kAlpha[i], Eigen::Vector3d::UnitX());
  return t;
}

struct Ur7e : ::testing::Test {
  static void SetUpTestSuite() {
    spec = new sim::RobotSpec(sim::load_robot(paths::config_dir() / "robots" / "ur7e.urdf"));
    const double base[3] = {0, 0, 0};
    const auto f = sim::robot_mjcf(*spec, base, 1.5);
    model = sim::compile_model("<mujoco><compiler angle=\"radian\"/><worldbody>" + f.body +
                                   "</worldbody><actuator>" + f.actuators + "</actuator><equality>" +
                                   f.equalities + "</equality></mujoco>",
                               "ur7e.urdf")
                .release();
  }
  static void TearDownTestSuite() {
    sim::ModelDeleter{}(model);
    delete spec;
  }
  static sim::RobotSpec* spec;
  static mjModel* model;
};
sim::RobotSpec* Ur7e::spec = nullptr;
mjModel* Ur7e::model = nullptr;

TEST_F(Ur7e, HasSixArmJointsWithUrsLimitsAndTwoFingers) {
  ASSERT_EQ(spec->arm.size(), 6u);
  EXPECT_EQ(spec->arm[0].name, "shoulder_pan");
  EXPECT_EQ(spec->arm[5].name, "wrist_3");
  for (const auto& j : spec->arm) EXPECT_NEAR(j.velocity, M_PI, 1e-9) << j.name;
  EXPECT_NEAR(spec->arm[2].upper, M_PI, 1e-9);  // the elbow
  EXPECT_NEAR(spec->arm[0].upper, 2 * M_PI, 1e-9);
  EXPECT_EQ(spec->arm[1].effort, 150);
  EXPECT_EQ(spec->arm[4].effort, 28);
  ASSERT_EQ(spec->fingers.size(), 2u);
  EXPECT_NEAR(2 * spec->fingers[0].upper, 0.085, 1e-12);  // the 2F-85's stroke
  // In the compiled model too (MJCF reads angles in degrees unless told otherwise).
  EXPECT_NEAR(model->jnt_range[2 * mj_name2id(model, mjOBJ_JOINT, "elbow") + 1], M_PI, 1e-9);
}

TEST_F(Ur7e, TheFlangeIsWhereUrsDhChainPutsItAtAnyJointValues) {
  auto d = sim::make_data(model);
  const int hand = mj_name2id(model, mjOBJ_BODY, "hand");
  const int tcp = mj_name2id(model, mjOBJ_SITE, "tcp");
  ASSERT_GE(hand, 0);
  ASSERT_GE(tcp, 0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-M_PI, M_PI);
  for (int trial = 0; trial < 50; ++trial) {
    std::array<double, 6> q{};
    for (int i = 0; i < 6; ++i) {
      q[i] = trial == 0 ? 0.0 : u(rng);
      d->qpos[model->jnt_qposadr[mj_name2id(model, mjOBJ_JOINT, spec->arm[i].name.c_str())]] = q[i];
    }
    mj_kinematics(model, d.get());
    const Eigen::Isometry3d want = dh_flange(q);
    const Eigen::Vector3d p(d->xpos[3 * hand], d->xpos[3 * hand + 1], d->xpos[3 * hand + 2]);
    EXPECT_LT((p - want.translation()).norm(), 1e-9) << "trial " << trial;
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = d->xmat[9 * hand + 3 * i + j];
    EXPECT_LT((r - want.linear()).norm(), 1e-9) << "trial " << trial;
    // The tool centre point: the pads' centre, 0.1415 m out along the flange's z axis.
    const Eigen::Vector3d tool = want * Eigen::Vector3d(0, 0, 0.1415);
    EXPECT_LT(
        (Eigen::Vector3d(d->site_xpos[3 * tcp], d->site_xpos[3 * tcp + 1], d->site_xpos[3 * tcp + 2]) - tool)
            .norm(),
        1e-9);
  }
  // At zero the arm lies stretched along -x: reach a2 + a3 = 0.8172 m, the flange d1 - d5 high.
  for (int i = 0; i < 6; ++i)
    d->qpos[model->jnt_qposadr[mj_name2id(model, mjOBJ_JOINT, spec->arm[i].name.c_str())]] = 0;
  mj_kinematics(model, d.get());
  EXPECT_NEAR(d->xpos[3 * hand], -0.8172, 1e-9);
  EXPECT_NEAR(d->xpos[3 * hand + 2], 0.1625 - 0.0997, 1e-9);
}

// `dh campaign --robot ur7e`: the UR7e on a benchmark scene's mount, behind the same controller and seam.
struct Ur7eWorkcell : ::testing::Test {
  static sim::Workcell cell(const std::string& robot) {
    const auto scene = paths::config_dir() / "scenes" / "kitchen_goal.yaml";
    return sim::Workcell(robot.empty() ? sim::load_scene(scene) : sim::load_scene(scene, sim::robot_profile(robot)));
  }
  static double angle(const Observation& a, const Observation& b) {
    const Eigen::Quaterniond qa(a.ee_q[0], a.ee_q[1], a.ee_q[2], a.ee_q[3]), qb(b.ee_q[0], b.ee_q[1], b.ee_q[2], b.ee_q[3]);
    return qa.angularDistance(qb);
  }
  /// Applies `a` for `steps` steps; the events of every step.
  static std::vector<sim::StepEvent> drive(sim::Workcell& c, const std::array<double, 7>& a, int steps) {
    std::vector<sim::StepEvent> all;
    for (int i = 0; i < steps; ++i)
      for (auto& e : c.step(a)) all.push_back(std::move(e));
    return all;
  }
};

TEST_F(Ur7eWorkcell, StartsWithTheToolWhereThePandasIsAndOpen) {
  auto panda = cell(""), ur = cell("ur7e");
  EXPECT_EQ(ur.scene().robot.arm.size(), 6u);
  panda.reset(21, {});
  ur.reset(21, {});
  const Observation p = panda.observe(), u = ur.observe();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(u.ee_p[k], p.ee_p[k], 0.005) << "axis " << k;
  EXPECT_LT(angle(u, p), 0.02);
  EXPECT_NEAR(u.gripper_opening, robot::kJawMaxGapM, 0.002);
  EXPECT_EQ(u.q[6], 0.0) << "a 6-joint arm leaves the seventh joint of the observation 0";
  EXPECT_NE(u.q[0], 0.0);
  // The same free objects, placed by the same seed: only the arm differs.
  ASSERT_EQ(u.entities.size(), p.entities.size());
  for (std::size_t i = 0; i < p.entities.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(u.entities[i].p[k], p.entities[i].p[k], 1e-6) << p.entities[i].name;
}

TEST_F(Ur7eWorkcell, AnActionMovesTheToolAsFarAsOnThePandaWithinTheEnvelopeAndTheJawCloses) {
  auto panda = cell(""), ur = cell("ur7e");
  panda.reset(21, {});
  ur.reset(21, {});
  const Observation p0 = panda.observe(), u0 = ur.observe();
  const std::array<double, 7> forward_down{0.6, 0.3, -0.4, 0, 0, 0, -1};
  const auto panda_events = drive(panda, forward_down, 12);
  const auto ur_events = drive(ur, forward_down, 12);
  const Observation p1 = panda.observe(), u1 = ur.observe();
  for (int k = 0; k < 3; ++k) {
    const double moved_p = p1.ee_p[k] - p0.ee_p[k], moved_u = u1.ee_p[k] - u0.ee_p[k];
    EXPECT_NEAR(moved_u, moved_p, 0.15 * std::abs(moved_p) + 0.002) << "axis " << k;
  }
  EXPECT_LT(angle(u1, u0), 0.03) << "a translation keeps the tool's orientation";
  for (const auto& e : ur_events) EXPECT_NE(e.kind, sim::StepEvent::SafetyHold) << e.reason;
  // A turn about the vertical as far as the Panda's, then the jaw shut on nothing.
  drive(panda, {0, 0, 0, 0, 0, 0.5, -1}, 6);
  drive(ur, {0, 0, 0, 0, 0, 0.5, -1}, 6);
  const double turned_p = angle(panda.observe(), p1), turned_u = angle(ur.observe(), u1);
  EXPECT_GT(turned_p, 0.25);
  EXPECT_NEAR(turned_u, turned_p, 0.15 * turned_p);
  drive(ur, {0, 0, 0, 0, 0, 0, 1}, 12);
  EXPECT_LT(ur.observe().gripper_opening, robot::kJawShutM);
}

// What each profile declares of its jaw (the skills plan contact with it) is what its model's collision
// boxes give, measured in the tool's frame at the ready pose.
TEST_F(Ur7eWorkcell, EachProfilesGripperIsWhatItsModelsBoxesGive) {
  for (const std::string robot : {"", "ur7e"}) {
    auto c = cell(robot);
    c.reset(21, {});
    const mjModel* m = c.model();
    const mjData* d = c.data();
    const int tcp = mj_name2id(m, mjOBJ_SITE, "tcp");
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> tool(d->site_xmat + 9 * tcp);
    const Eigen::Vector3d at(d->site_xpos + 3 * tcp);
    robot::Gripper seen{0, 0, 0, 0};
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_contype[g] == 0 && m->geom_conaffinity[g] == 0) continue;
      const std::string body = mj_id2name(m, mjOBJ_BODY, m->geom_bodyid[g]);
      if (body != "hand" && body != "finger_left_link" && body != "finger_right_link") continue;
      ASSERT_EQ(m->geom_type[g], mjGEOM_BOX) << body;
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(d->geom_xmat + 9 * g);
      const Eigen::Vector3d half(m->geom_size + 3 * g), centre(d->geom_xpos + 3 * g);
      const auto reach = [&](const Eigen::Vector3d& axis) { return (r.transpose() * axis).cwiseAbs().dot(half); };
      const double along = (centre - at).dot(tool.col(2));  // the tool's axis points from the hand to the pads
      if (body == "hand") {
        seen.hand_above_tcp = std::max(seen.hand_above_tcp, reach(tool.col(2)) - along);
      } else {
        seen.pad_below_tcp = std::max(seen.pad_below_tcp, along + reach(tool.col(2)));
        seen.pad_half_width = std::max(seen.pad_half_width, reach(tool.col(0)));
        seen.pad_thickness = std::max(seen.pad_thickness, 2 * reach(tool.col(1)));
      }
    }
    const robot::Gripper& declared = c.scene().gripper;
    const std::string who = robot.empty() ? "panda" : robot;
    EXPECT_NEAR(seen.pad_below_tcp, declared.pad_below_tcp, 1e-4) << who;
    EXPECT_NEAR(seen.pad_half_width, declared.pad_half_width, 1e-4) << who;
    EXPECT_NEAR(seen.pad_thickness, declared.pad_thickness, 1e-4) << who;
    EXPECT_NEAR(seen.hand_above_tcp, declared.hand_above_tcp, 1e-3) << who;
    EXPECT_EQ(c.observe().gripper, declared) << who << ": every observation carries it";
  }
}

TEST(RobotModel, RefusesAnArmOfAnotherJointCountNamingTheFile) {
  const auto dir = std::filesystem::temp_directory_path() / "dh_robot_model_test";
  std::filesystem::create_directories(dir);
  const auto file = dir / "two_joints.urdf";
  std::ofstream(file) << R"(<robot name="r"><link name="a"/><link name="b"/><link name="tcp"/>
    <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
      <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
    <joint name="j2" type="revolute"><parent link="b"/><child link="tcp"/><axis xyz="0 0 1"/>
      <limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>)";
  try {
    sim::load_robot(file);
    FAIL() << "a 2-joint arm was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("two_joints.urdf: expected 6 or 7 revolute arm joints, found 2"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dh
