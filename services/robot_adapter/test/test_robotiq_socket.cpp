// A Robotiq gripper through its URCap's socket: the lines, the client against the test double's server
// over loopback, the gap its readings mean, and the cell's observation of the UR7e's jaw with it.
#include <gtest/gtest.h>

#include <map>

#include "dh/common/paths.hpp"
#include "dh/rtde/robotiq_socket.hpp"
#include "dh/rtde/rtde_cell.hpp"
#include "dh/rtde/simulated_ur.hpp"

namespace dh::rtde {
namespace {

using namespace std::chrono_literals;

struct Registers {
  std::map<std::string, int> values{{"ACT", 0}, {"GTO", 0}, {"POS", 0}, {"STA", 0}};
  bool set(const std::string& var, int v) {
    if (!values.count(var)) return false;
    values[var] = v;
    if (var == "ACT") values["STA"] = v == 1 ? 3 : 0;
    return true;
  }
  std::optional<int> get(const std::string& var) const {
    const auto it = values.find(var);
    return it == values.end() ? std::nullopt : std::optional(it->second);
  }
};

TEST(RobotiqLines, AreAnsweredAsTheUrcapsServerAnswersThem) {
  Registers r;
  const auto set = [&](const std::string& v, int x) { return r.set(v, x); };
  const auto get = [&](const std::string& v) { return r.get(v); };
  EXPECT_EQ(robotiq_answer("SET POS 255", set, get), "ack");
  EXPECT_EQ(r.values["POS"], 255);
  EXPECT_EQ(robotiq_answer("SET ACT 1 GTO 1", set, get), "ack");
  EXPECT_EQ(robotiq_answer("GET STA", set, get), "STA 3");
  EXPECT_EQ(robotiq_answer("GET XYZ", set, get), "?");
  EXPECT_EQ(robotiq_answer("SET POS", set, get), "?");
  EXPECT_EQ(robotiq_answer("SET POS two", set, get), "?");
  EXPECT_EQ(robotiq_answer("rq_open()", set, get), "?");
}

TEST(RobotiqGap, RunsFromTheStrokeOpenToShutTouching) {
  const RobotiqRange range;
  EXPECT_DOUBLE_EQ(robotiq_gap(3, range, 0.085), 0.085);
  EXPECT_DOUBLE_EQ(robotiq_gap(230, range, 0.085), 0.0);
  EXPECT_NEAR(robotiq_gap(116, range, 0.085), 0.085 * 114 / 227, 1e-12);
  EXPECT_DOUBLE_EQ(robotiq_gap(0, range, 0.085), 0.085) << "clamped to the stroke";
  EXPECT_DOUBLE_EQ(robotiq_gap(255, range, 0.085), 0.0);
}

TEST(RobotiqClient, ActivatesSetsAndReadsOverLoopback) {
  Registers r;
  RobotiqServer server([&](const std::string& v, int x) { return r.set(v, x); },
                       [&](const std::string& v) { return r.get(v); });
  RobotiqClient c;
  c.connect("127.0.0.1", server.port(), 1s);
  r.values["SPE"] = r.values["FOR"] = 0;
  c.activate(100, 1s);
  EXPECT_EQ(r.values["ACT"], 1);
  EXPECT_EQ(r.values["GTO"], 1);
  EXPECT_EQ(r.values["FOR"], 100);
  c.set({{"POS", 200}}, 1s);
  EXPECT_EQ(c.get("POS", 1s), 200);
  try {
    c.get("XYZ", 1s);
    FAIL() << "an unknown variable was read";
  } catch (const GripperError& e) {
    EXPECT_NE(std::string(e.what()).find("'GET XYZ' answered '?'"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(c.connected()) << "a failed exchange ends the session";
  c.connect("127.0.0.1", server.port(), 1s);  // the server takes the next client
  EXPECT_EQ(c.get("POS", 1s), 200);
}

TEST(RobotiqClient, AGripperThatNeverBecomesActiveIsNamed) {
  Registers r;
  RobotiqServer server([&](const std::string& v, int x) { return v == "ACT" || r.set(v, x); },  // STA stays 0
                       [&](const std::string& v) { return r.get(v); });
  RobotiqClient c;
  c.connect("127.0.0.1", server.port(), 1s);
  try {
    c.activate(100, 200ms);
    FAIL() << "activated";
  } catch (const GripperError& e) {
    EXPECT_NE(std::string(e.what()).find("not active within 200 ms of ACT 1 (STA 0)"), std::string::npos)
        << e.what();
  }
}

TEST(RobotiqClient, NoServerIsNamed) {
  const std::uint16_t port = [] {
    Registers r;
    RobotiqServer s([&](const std::string& v, int x) { return r.set(v, x); },
                    [&](const std::string& v) { return r.get(v); });
    return s.port();
  }();  // its server is gone
  RobotiqClient c;
  try {
    c.connect("127.0.0.1", port, 1s);
    FAIL() << "connected to nothing";
  } catch (const GripperError& e) {
    EXPECT_NE(std::string(e.what()).find("is the Robotiq URCap installed"), std::string::npos) << e.what();
  }
}

// The cell reads the UR7e's jaw through the URCap's socket: the gap from its fingers' position, and no
// contact when it shuts on nothing.
struct RobotiqCell : ::testing::Test {
  SimulatedController controller{paths::config_dir() / "robots" / "ur7e.urdf", {0, -1.3, 1.6, -1.87, -1.5708, 0}};
  RtdeCellConfig config() {
    RtdeCellConfig c;
    c.rtde_port = controller.port();
    c.script_port = controller.script_port();
    c.gripper_port = controller.gripper_port();
    c.gripper_interface = RtdeCellConfig::GripperInterface::RobotiqUrcap;
    return c;
  }
};

TEST_F(RobotiqCell, TheObservationCarriesTheJawsMeasuredGap) {
  RtdeCell cell(config());
  cell.connect();
  EXPECT_EQ(controller.with_arm([](SimulatedUr& a) { return a.robotiq_get("STA"); }), 3)
      << "activated at connect";
  Observation o = cell.observe();
  EXPECT_NEAR(o.gripper_opening, 0.085, 0.002) << "open";
  EXPECT_FALSE(o.contact_left || o.contact_right);
  for (int i = 0; i < 20; ++i) cell.step({0, 0, 0, 0, 0, 0, 1});
  o = cell.observe();
  EXPECT_LT(o.gripper_opening, 0.002) << "shut";
  EXPECT_FALSE(o.contact_left || o.contact_right) << "shut on nothing: no object";
  EXPECT_FALSE(o.holding());
  for (int i = 0; i < 20; ++i) cell.step({0, 0, 0, 0, 0, 0, -1});
  EXPECT_NEAR(cell.observe().gripper_opening, 0.085, 0.002) << "open again";
}

TEST_F(RobotiqCell, AGripperThatCannotBeReachedStopsTheConnectNamingIt) {
  RtdeCellConfig c = config();
  c.gripper_port = controller.port();  // RTDE's port: it does not answer lines
  c.timeout = 300ms;
  RtdeCell cell(c);
  try {
    cell.connect();
    FAIL() << "connected";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("gripper:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the arm is stopped"), std::string::npos) << e.what();
  }
}

// A gripper in fault (FLT nonzero) ends the step, or the connect, naming the code; the arm is stopped.
TEST_F(RobotiqCell, AGrippersFaultEndsTheStepNamingItsCode) {
  {
    RtdeCell cell(config());
    cell.connect();
    cell.step({0, 0, 0, 0, 0, 0, -1});
    controller.with_arm([](SimulatedUr& a) { a.robotiq_fault(0x0E); });
    try {
      cell.step({0.5, 0, 0, 0, 0, 0, 1});
      FAIL() << "stepped with the gripper in fault";
    } catch (const CellStopped& e) {
      EXPECT_NE(std::string(e.what()).find("gripper: fault 0x0E, overcurrent"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("the arm is stopped"), std::string::npos) << e.what();
    }
  }
  RtdeCell again(config());
  try {
    again.connect();
    FAIL() << "connected to a gripper in fault";
  } catch (const CellStopped& e) {
    EXPECT_NE(std::string(e.what()).find("fault 0x0E"), std::string::npos) << e.what();
  }
  controller.with_arm([](SimulatedUr& a) { a.robotiq_fault(0); });
  RtdeCell cleared(config());
  EXPECT_NO_THROW(cleared.connect()) << "the fault cleared";
}

TEST(RobotiqFault, CodesAreNamedAndAnUnknownOneSaysSo) {
  EXPECT_EQ(robotiq_fault_text(0), "no fault");
  EXPECT_NE(robotiq_fault_text(0x0A).find("under its minimum operating voltage"), std::string::npos);
  EXPECT_NE(robotiq_fault_text(0x08).find("minor fault"), std::string::npos);
  EXPECT_EQ(robotiq_fault_text(0x42), "unknown fault code");
}

}  // namespace
}  // namespace dh::rtde
