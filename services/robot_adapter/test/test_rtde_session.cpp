// A client and the test controller in one RTDE session over loopback TCP: the handshake, recipes (a
// refused field named), outputs streamed at the recipe's frequency, inputs reaching the controller; and
// a controller that stops answering, drops the link or is not there ends the call with the step named, and
// only after what came before the deadline is read.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "dh/rtde/client.hpp"
#include "dh/rtde/test_controller.hpp"

using namespace dh::rtde;
using namespace std::chrono_literals;

namespace {

ControllerModel ur_outputs() {
  ControllerModel m;
  m.outputs = {{"timestamp", FieldType::Double},
               {"actual_q", FieldType::Vector6d},
               {"safety_status_bits", FieldType::Uint32},
               {"runtime_state", FieldType::Uint32}};
  m.inputs = {{"input_int_register_24", FieldType::Int32}, {"input_double_register_24", FieldType::Double}};
  return m;
}

struct Session : ::testing::Test {
  std::atomic<double> t{0};
  static Value value(const std::string& name, double t) {
    if (name == "timestamp") return t;
    if (name == "actual_q") return std::array<double, 6>{0, -1.57, 1.57, -1.57, -1.57, 0};
    if (name == "safety_status_bits") return std::uint32_t{1};  // normal
    return std::uint32_t{2};                                    // playing
  }
  TestController controller{ur_outputs(), [this](const std::vector<std::string>& names) {
                              std::vector<Value> v;
                              for (const auto& n : names) v.push_back(value(n, t.load()));
                              return v;
                            }};
  Client client;
};

}  // namespace

TEST_F(Session, AClientSetsUpStreamsAndWrites) {
  client.connect("127.0.0.1", controller.port(), 2s);
  EXPECT_EQ(client.controller_version(1s).major, 5u);
  const Recipe out = client.setup_outputs(125, {"timestamp", "actual_q", "safety_status_bits"}, 1s);
  EXPECT_EQ(out.types, (std::vector<FieldType>{FieldType::Double, FieldType::Vector6d, FieldType::Uint32}));
  const Recipe in = client.setup_inputs({"input_int_register_24", "input_double_register_24"}, 1s);
  EXPECT_NE(in.id, out.id);
  t = 1.25;
  // At 125 Hz the 25th package is due 24 periods (192 ms) after the start: paced, not sent at once.
  const auto t0 = std::chrono::steady_clock::now();
  client.start(1s);
  std::vector<Value> last;
  for (int i = 0; i < 25; ++i) last = client.receive(out, 1s);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 190ms) << "outputs come at the recipe's frequency";
  EXPECT_EQ(std::get<double>(last[0]), 1.25);
  EXPECT_EQ((std::get<std::array<double, 6>>(last[1])[1]), -1.57);
  EXPECT_EQ(std::get<std::uint32_t>(last[2]), 1u);
  client.send(in, {std::int32_t{25}, 0.35}, 1s);
  for (int i = 0; i < 100 && controller.inputs().size() < 2; ++i) std::this_thread::sleep_for(5ms);
  const auto inputs = controller.inputs();
  ASSERT_EQ(inputs.size(), 2u);
  EXPECT_EQ(std::get<std::int32_t>(inputs.at("input_int_register_24")), 25);
  EXPECT_EQ(std::get<double>(inputs.at("input_double_register_24")), 0.35);
  client.pause(1s);
  client.close();
}

TEST_F(Session, ARefusedFieldIsNamedAndTheSessionCloses) {
  client.connect("127.0.0.1", controller.port(), 2s);
  try {
    client.setup_outputs(125, {"timestamp", "actual_TCP_force"}, 1s);
    ADD_FAILURE() << "a field the controller does not serve was accepted";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("actual_TCP_force (NOT_FOUND)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("setup outputs"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(client.connected());
  EXPECT_THROW(client.start(1s), ClientError) << "closed: reconnect and set up again";
}

TEST_F(Session, StartWithoutAnOutputRecipeIsRefused) {
  client.connect("127.0.0.1", controller.port(), 2s);
  EXPECT_THROW(client.start(1s), ClientError);
}

TEST_F(Session, AControllerThatStopsAnsweringOrDropsTheLinkEndsTheCallWithItsStep) {
  client.connect("127.0.0.1", controller.port(), 2s);
  const Recipe out = client.setup_outputs(250, {"timestamp"}, 1s);
  client.start(1s);
  client.receive(out, 1s);
  controller.set_silent(true);
  try {
    for (int i = 0; i < 1000; ++i) client.receive(out, 200ms);  // what was in flight, then silence
    ADD_FAILURE() << "a silent controller kept sending";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("receive: no answer"), std::string::npos) << e.what();
  }
  controller.set_silent(false);
  // A reconnect mid-session sets up again; then the link is cut.
  client.connect("127.0.0.1", controller.port(), 2s);
  const Recipe again = client.setup_outputs(250, {"timestamp"}, 1s);
  client.start(1s);
  client.receive(again, 1s);
  controller.drop_client();
  try {
    for (int i = 0; i < 1000; ++i) client.receive(again, 1s);
    ADD_FAILURE() << "a dropped link kept delivering";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("closed the connection"), std::string::npos) << e.what();
  }
}

TEST_F(Session, ACallerPastItsDeadlineReadsWhatCameMeanwhileBeforeCallingItLost) {
  client.connect("127.0.0.1", controller.port(), 2s);
  const Recipe out = client.setup_outputs(250, {"timestamp"}, 1s);
  client.start(1s);
  client.receive(out, 1s);
  std::this_thread::sleep_for(50ms);  // outputs come in while nobody reads
  // A zero timeout is a caller that woke after its deadline: what is in the socket is still read.
  EXPECT_NO_THROW(client.receive(out, 0ms));
  controller.set_silent(true);
  std::this_thread::sleep_for(50ms);
  try {
    for (int i = 0; i < 1000; ++i) client.receive(out, 0ms);  // what came before the silence, then none
    ADD_FAILURE() << "a silent controller kept sending";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("receive: no answer"), std::string::npos) << e.what();
  }
}

TEST(RtdeClient, NoControllerIsNamedWithItsAddress) {
  std::uint16_t port = 0;
  {
    TestController gone(ControllerModel{}, [](const std::vector<std::string>& names) {
      return std::vector<Value>(names.size(), 0.0);
    });
    port = gone.port();
  }
  Client client;
  try {
    client.connect("127.0.0.1", port, 1s);
    ADD_FAILURE() << "connected to a closed port";
  } catch (const ClientError& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(port)), std::string::npos) << e.what();
  }
}
