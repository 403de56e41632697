// The UR arm as the seam's cell, end to end over loopback: RtdeCell sends the servo program and its
// targets over RTDE to the test controller, whose UR7e in MuJoCo runs the program's contract. What a
// step does to the tool, and what stops the arm: a silent adapter, a protective stop, a cut link, the
// envelope.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/rtde/rtde_cell.hpp"
#include "dh/rtde/simulated_ur.hpp"

namespace dh::rtde {
namespace {

using namespace std::chrono_literals;

// Tool down, 0.5 m in front of the base (x < 0: the UR's zero points its arm along -x).
constexpr std::array<double, 6> kReady{0, -1.3, 1.6, -1.87, -1.5708, 0};

struct Cell : ::testing::Test {
  SimulatedController controller{paths::config_dir() / "robots" / "ur7e.urdf", kReady};
  RtdeCellConfig config() {
    RtdeCellConfig c;
    c.rtde_port = controller.port();
    c.script_port = controller.script_port();
    return c;
  }
  static double peak_over(SimulatedController& c, std::chrono::milliseconds window) {
    c.with_arm([](SimulatedUr& a) { a.reset_peak(); });
    std::this_thread::sleep_for(window);
    return c.with_arm([](SimulatedUr& a) { return a.peak_speed(); });
  }
};

// The jaw's shape the cell reports is the one the UR7e's robot profile declares (and its model has).
TEST(CellGripper, IsTheUr7eProfiles) {
  const ConfigNode g = ConfigNode::load_file(paths::config_dir() / "robots" / "ur7e.yaml").child("gripper");
  const robot::Gripper profile{g.get<double>("pad_below_tcp"), g.get<double>("pad_half_width"),
                               g.get<double>("pad_thickness"), g.get<double>("hand_above_tcp")};
  EXPECT_EQ(RtdeCellConfig{}.gripper, profile);
}

TEST_F(Cell, StartsTheProgramAndMovesTheToolAsFarPerStepAsTheSimulator) {
  RtdeCell cell(config());
  cell.connect();
  EXPECT_TRUE(controller.with_arm([](SimulatedUr& a) { return a.program_running(); }));
  const Observation start = cell.observe();
  EXPECT_EQ(start.gripper, RtdeCellConfig{}.gripper);
  constexpr int kSteps = 10;
  for (int i = 0; i < kSteps; ++i) {
    const auto events = cell.step({0, 0.5, 0, 0, 0, 0, -1});
    EXPECT_TRUE(events.empty()) << events.front().reason;
  }
  const Observation end = cell.observe();
  // servo.hpp: 0.0133 m per step at |a| = 1, so 10 steps at a = 0.5 cover 0.066 m; the arm lags the
  // last target by part of a step.
  EXPECT_NEAR(end.ee_p[1] - start.ee_p[1], kSteps * 0.5 * 0.05 * 0.2655, 0.02);
  EXPECT_NEAR(end.ee_p[0], start.ee_p[0], 0.01);
  EXPECT_NEAR(end.ee_p[2], start.ee_p[2], 0.01);
  EXPECT_GT(cell.state().applied, 0);
  cell.step({0, 0, 0, 0, 0, 0, 1});
  EXPECT_TRUE(cell.state().gripper_closed);
  EXPECT_EQ(cell.observe().gripper_opening, 0.0);
}

TEST_F(Cell, AnAdapterThatFallsSilentLeavesTheArmStoppedByTheWatchdog) {
  RtdeCell cell(config());
  cell.connect();
  for (int i = 0; i < 6; ++i) cell.step({0, 1, 0, 0, 0, 0, -1});
  EXPECT_GT(controller.with_arm([](SimulatedUr& a) { return a.peak_speed(); }), 0.05);
  // No target for longer than the watchdog (0.1 s) and the arm has come to rest: no motion after.
  std::this_thread::sleep_for(300ms);
  EXPECT_LT(peak_over(controller, 300ms), 1e-3);
  EXPECT_EQ(std::get<std::int32_t>(
                controller.with_arm([](SimulatedUr& a) { return a.output(ServoProgram::kAppliedRegister); })),
            0);
}

TEST_F(Cell, AProtectiveStopEndsTheStepWithItsReasonAndTheArmStays) {
  RtdeCell cell(config());
  cell.connect();
  cell.step({0, 1, 0, 0, 0, 0, -1});
  controller.with_arm([](SimulatedUr& a) { a.protective_stop(); });
  try {
    cell.step({0, 1, 0, 0, 0, 0, -1});
    FAIL() << "a step ran through a protective stop";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("protective stop (safety_status_bits 0x4)"), std::string::npos)
        << e.what();
  }
  std::this_thread::sleep_for(200ms);
  EXPECT_LT(peak_over(controller, 300ms), 1e-3);
}

TEST_F(Cell, ACutLinkEndsTheStepNamingItAndTheWatchdogStopsTheArm) {
  RtdeCell cell(config());
  cell.connect();
  for (int i = 0; i < 3; ++i) cell.step({0, 1, 0, 0, 0, 0, -1});
  controller.controller().drop_client();
  try {
    for (int i = 0; i < 5; ++i) cell.step({0, 1, 0, 0, 0, 0, -1});
    FAIL() << "steps went on over a cut link";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("the link to the controller was lost"), std::string::npos)
        << e.what();
  }
  std::this_thread::sleep_for(300ms);
  EXPECT_LT(peak_over(controller, 300ms), 1e-3);
}

TEST_F(Cell, AfterAReleasedProtectiveStopTheNextSessionRunsTheProgramAgain) {
  RtdeCell cell(config());
  cell.connect();
  cell.step({0, 1, 0, 0, 0, 0, 1});
  controller.with_arm([](SimulatedUr& a) { a.protective_stop(); });
  EXPECT_THROW(cell.step({0, 1, 0, 0, 0, 0, 1}), CellStopped);
  EXPECT_FALSE(cell.connected()) << "the session ends with the stop";
  controller.with_arm([](SimulatedUr& a) { a.release_protective_stop(); });
  cell.connect();
  const double y = cell.observe().ee_p[1];
  EXPECT_TRUE(cell.state().gripper_closed) << "a new session keeps what the jaw holds";
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(cell.step({0, 1, 0, 0, 0, 0, 1}).empty());
  EXPECT_GT(cell.observe().ee_p[1] - y, 0.02);
}

TEST_F(Cell, ABaseTurnedInTheWorldMovesTheToolInTheWorldFrame) {
  auto c = config();
  c.base_xyz = {0.4, -0.1, 0.02};
  c.base_yaw = M_PI / 2;
  RtdeCell cell(c);
  cell.connect();
  const Observation start = cell.observe();
  // The tool's place in the world is the base's transform of the controller's base-frame pose.
  const auto tcp = cell.state().tcp;
  EXPECT_NEAR(start.ee_p[0], 0.4 - tcp[1], 1e-9);
  EXPECT_NEAR(start.ee_p[1], -0.1 + tcp[0], 1e-9);
  EXPECT_NEAR(start.ee_p[2], 0.02 + tcp[2], 1e-9);
  EXPECT_EQ(start.base_p, c.base_xyz) << "the observation says where the base stands";
  for (int i = 0; i < 8; ++i) cell.step({0.6, 0, 0, 0, 0, 0, -1});
  const Observation end = cell.observe();
  EXPECT_NEAR(end.ee_p[0] - start.ee_p[0], 8 * 0.6 * 0.05 * 0.2655, 0.02) << "world +x";
  EXPECT_NEAR(end.ee_p[1], start.ee_p[1], 0.01);
}

TEST_F(Cell, AControllerWithAnotherTcpIsRefusedNamingIt) {
  auto c = config();
  c.tcp_offset[2] = 0.2;
  RtdeCell cell(c);
  try {
    cell.connect();
    FAIL() << "connected with the wrong TCP";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("the controller's TCP is [0.0000, 0.0000, 0.1415"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("set it on the teach pendant"), std::string::npos) << e.what();
  }
}

TEST(CellSetup, AControllerOlderThanTheESeriesIsRefusedNamingItsVersion) {
  ControllerModel old = SimulatedUr::model();
  old.version = {3, 15, 0, 0};
  TestController cb3(
      old, [](const std::vector<std::string>& names) { return std::vector<Value>(names.size(), 0.0); });
  RtdeCellConfig c;
  c.rtde_port = cb3.port();
  c.script_port = cb3.script_port();
  RtdeCell cell(c);
  try {
    cell.connect();
    FAIL() << "connected to a CB3 controller";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("controller software 3.15 is older than the e-Series' 5.x"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(cell.connected());
}

TEST_F(Cell, AnArmInAProtectiveStopIsNamedAtConnect) {
  controller.with_arm([](SimulatedUr& a) { a.protective_stop(); });
  RtdeCell cell(config());
  try {
    cell.connect();
    FAIL() << "connected to an arm in a protective stop";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("release it on the teach pendant"), std::string::npos) << e.what();
  }
}

TEST_F(Cell, ObservationsCarryTheCellsEntities) {
  auto c = config();
  EntityState cabinet;
  cabinet.name = "cabinet";
  cabinet.kind = "cabinet";
  c.entities = {cabinet};
  RtdeCell cell(c);
  cell.connect();
  const Observation o = cell.observe();
  ASSERT_EQ(o.entities.size(), 1u);
  EXPECT_EQ(o.entities[0].name, "cabinet");
}

TEST_F(Cell, AGarbageActionIsAppliedClampedAndSaidSo) {
  RtdeCell cell(config());
  cell.connect();
  const auto events = cell.step({std::nan(""), 5, 0, 0, 0, 0, -1});
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, sim::StepEvent::ActionClamped);
  EXPECT_NE(events[0].reason.find("action component 0 = nan"), std::string::npos) << events[0].reason;
}

TEST_F(Cell, TheEnvelopeHoldsTheArm) {
  auto c = config();
  c.limits.joint_speed = 0.02;  // rad/s: any real motion breaches it
  RtdeCell cell(c);
  cell.connect();
  bool held = false;
  for (int i = 0; i < 4 && !held; ++i)
    for (const auto& e : cell.step({0, 1, 0, 0, 0, 0, -1})) held |= e.kind == sim::StepEvent::SafetyHold;
  EXPECT_TRUE(held);
}

TEST_F(Cell, TheWorkspaceBoxClampsTheTarget) {
  auto w = config();
  double y = 0;
  {
    RtdeCell probe(w);  // one client at a time: it disconnects at the scope's end
    probe.connect();
    y = probe.observe().ee_p[1];
  }
  w.limits.workspace_max[1] = y + 0.005;
  RtdeCell cell(w);
  cell.connect();
  const auto events = cell.step({0, 1, 0, 0, 0, 0, -1});
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, sim::StepEvent::WorkspaceClamp);
  cell.step({0, 1, 0, 0, 0, 0, -1});
  EXPECT_LT(cell.observe().ee_p[1], y + 0.005 + 0.003);
}

}  // namespace
}  // namespace dh::rtde
