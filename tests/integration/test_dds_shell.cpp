// The one DDS shell (dds_shell.hpp) over real DDS, with a test binding run in this process: samples reach
// their handler and the process's own samples of a kSkipOwn input do not; work posted from another thread
// is written from the loop; a loop held longer than its allowance loses the liveliness of its announcement
// and gets it back; a binding whose ports differ from its core's declaration is refused at configure, and
// the reason names the topic. With lanes: a sample reaches its lane's own thread, one that is no lane's the
// binding's handler; a held lane costs the process its liveliness while the other lanes go on; a lane's
// exception ends the process with it as the reason.
#include <spdlog/sinks/ostream_sink.h>

#include <sstream>

#include "dh/common/dds_shell.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;

namespace {

/// Echoes every command it reads as a status with the command's id; "post" is echoed from another thread
/// through Context::post, "block" holds the loop for 2.5 s.
struct EchoBinding {
  using Inputs = dds::Inputs<dds::In<port::Command, dds::kSkipOwn>>;
  using Outputs = dds::Outputs<port::Command, port::CommandStatus, port::Announce>;
  using Context = dds::Context<EchoBinding>;

  std::string name() const { return "dh_test_echo"; }
  std::string description() const { return "a test binding that echoes commands"; }
  const Ports& ports() const {
    static const Ports p{in_port<port::Command>("commands"), out_port<port::Command>("its own command"),
                         out_port<port::CommandStatus>("the echo"), out_port<port::Announce>("liveliness")};
    static const Ports missing{in_port<port::Command>("commands"), out_port<port::CommandStatus>("the echo"),
                               out_port<port::Announce>("liveliness")};
    return declare_all ? p : missing;
  }
  void options(CLI::App&) {}
  void configure(Context&) {}
  void activate(Context& ctx) {
    msg::CapabilityAnnounce a;
    a.capability("echo");
    a.instance("echo@test");
    ctx.write<port::Announce>(a);
    msg::Command own;
    own.command_id("own");
    ctx.write<port::Command>(own);  // read back by its own reader, and dropped there
  }
  void on(const dds::Sample<port::Command>& s, Context& ctx) {
    const std::string id = s.msg.command_id();
    if (id == "block") std::this_thread::sleep_for(2500ms);
    if (id == "post") {
      std::thread([&ctx, id] { ctx.post([&ctx, id] { echo(ctx, id + " (posted)"); }); }).detach();
      return;
    }
    echo(ctx, id);
  }
  static void echo(Context& ctx, const std::string& id) {
    msg::CommandStatus st;
    st.command_id(id);
    ctx.write<port::CommandStatus>(st);
  }

  bool declare_all = true;
};

struct LaneBinding;
using LaneContext = dds::Context<LaneBinding>;

/// Echoes a command as "lane<k>:<id>" from its own thread; "block" holds it 2.5 s, "throw" throws.
struct EchoLane {
  unsigned k;
  void on(const dds::Sample<port::Command>& s, LaneContext& ctx);
};

/// Routes commands by channel: channels 0 and 1 to lanes 0 and 1, any other to its own handler ("loop:<id>").
struct LaneBinding {
  using Inputs = dds::Inputs<dds::In<port::Command>>;
  using Outputs = dds::Outputs<port::CommandStatus, port::Announce>;
  using Lane = EchoLane;

  std::string name() const { return "dh_test_lanes"; }
  std::string description() const { return "a test binding with two lanes"; }
  const Ports& ports() const {
    static const Ports p{in_port<port::Command>("commands"), out_port<port::CommandStatus>("the echo"),
                         out_port<port::Announce>("liveliness")};
    return p;
  }
  void options(CLI::App&) {}
  void configure(LaneContext&) {}
  void activate(LaneContext& ctx) {
    msg::CapabilityAnnounce a;
    a.capability("lanes");
    a.instance("lanes@test");
    ctx.write<port::Announce>(a);
  }
  unsigned lanes() const { return 2; }
  EchoLane& lane(unsigned i) { return lanes_[i]; }
  std::optional<unsigned> lane_of(const msg::Command& c) const {
    return c.channel() < 2 ? std::optional<unsigned>(c.channel()) : std::nullopt;
  }
  void on(const dds::Sample<port::Command>& s, LaneContext& ctx) { echo(ctx, "loop:" + s.msg.command_id()); }
  static void echo(LaneContext& ctx, const std::string& id) {
    msg::CommandStatus st;
    st.command_id(id);
    ctx.write<port::CommandStatus>(st);
  }

  EchoLane lanes_[2]{{0}, {1}};
};

void EchoLane::on(const dds::Sample<port::Command>& s, LaneContext& ctx) {
  const std::string id = s.msg.command_id();
  if (id == "block") std::this_thread::sleep_for(2500ms);
  if (id == "throw") throw std::runtime_error("lane " + std::to_string(k) + " was told to fail");
  LaneBinding::echo(ctx, "lane" + std::to_string(k) + ":" + id);
}

struct DdsShell : ::testing::Test {
  itest::IsolatedEnv env;
  std::ostringstream log_text;
  std::shared_ptr<spdlog::logger> log =
      std::make_shared<spdlog::logger>("dh_test_echo", std::make_shared<spdlog::sinks::ostream_sink_mt>(log_text));
  EchoBinding binding;
  std::optional<std::thread> shell;
  int exit_code = -1;

  std::mutex m;
  std::condition_variable cv;
  std::vector<std::string> echoed;
  int lost = 0, regained = 0, announced = 0;
  std::optional<dds::Participant> p;
  std::optional<dds::Reader<msg::CommandStatusPubSubType>> statuses;
  std::optional<dds::Reader<msg::CapabilityAnnouncePubSubType>> announcements;
  std::optional<dds::Writer<msg::CommandPubSubType>> commands;

  void SetUp() override {
    p.emplace("itest");
    statuses.emplace(*p, std::string(port::CommandStatus::topic), port::CommandStatus::qos,
                     dds::Reader<msg::CommandStatusPubSubType>::Callbacks{
                         [this](const msg::CommandStatus& s, const auto&) {
                           std::lock_guard l(m);
                           echoed.push_back(s.command_id());
                           cv.notify_all();
                         },
                         {},
                         {}});
    announcements.emplace(*p, std::string(port::Announce::topic), port::Announce::qos,
                          dds::Reader<msg::CapabilityAnnouncePubSubType>::Callbacks{
                              [this](const msg::CapabilityAnnounce&, const auto&) {
                                std::lock_guard l(m);
                                ++announced;
                                cv.notify_all();
                              },
                              [this](const dds::fdds::LivelinessChangedStatus& s) {
                                std::lock_guard l(m);
                                if (s.not_alive_count_change > 0) ++lost;
                                if (s.alive_count_change > 0 && lost > 0) ++regained;
                                cv.notify_all();
                              },
                              {}});
    commands.emplace(*p, std::string(port::Command::topic), port::Command::qos);
  }
  void start() {
    shell.emplace([this] { exit_code = dds::Shell<EchoBinding>(binding, *log).run(); });
  }
  LaneBinding lanes;
  void start_lanes() {
    shell.emplace([this] { exit_code = dds::Shell<LaneBinding>(lanes, *log).run(); });
  }
  void TearDown() override {
    request_shutdown();
    if (shell) shell->join();
  }
  void send(const std::string& id, std::uint32_t channel = 0) {
    msg::Command c;
    c.channel(channel);
    c.command_id(id);
    commands->write(c);
  }
  bool saw(const std::string& id, std::chrono::milliseconds within) {
    return itest::wait_until(m, cv, within, [&] { return std::count(echoed.begin(), echoed.end(), id) > 0; });
  }
  /// Waits for the shell's announcement, then sends `id` until its echo `echo` comes back: the writers and
  /// readers of the two participants match in their own time.
  bool matched(const std::string& id, std::uint32_t channel, const std::string& echo) {
    if (!itest::wait_until(m, cv, 10s, [&] { return announced > 0; })) return false;
    for (int i = 0; i < 50 && !saw(echo, 200ms); ++i) send(id, channel);
    return saw(echo, 0ms);
  }
};

TEST_F(DdsShell, SamplesReachTheirHandlerOwnSamplesDoNotAndPostedWorkIsWrittenFromTheLoop) {
  start();
  ASSERT_TRUE(matched("first", 0, "first")) << log_text.str();
  send("post");
  EXPECT_TRUE(saw("post (posted)", 5s));
  std::lock_guard l(m);
  EXPECT_EQ(std::count(echoed.begin(), echoed.end(), "own"), 0) << "the shell delivered its own command back";
}

TEST_F(DdsShell, ALoopHeldLongerThanItsAllowanceLosesItsLivelinessAndGetsItBack) {
  start();
  ASSERT_TRUE(matched("first", 0, "first")) << log_text.str();
  {
    std::lock_guard l(m);
    ASSERT_EQ(lost, 0) << "liveliness lost while the loop turned";
  }
  send("block");  // holds the loop 2.5 s: more than the 1 s lease plus the 250 ms allowance
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return lost > 0; })) << "a stuck loop kept its liveliness";
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return regained > 0; })) << "the loop turns again, unasserted";
  EXPECT_TRUE(saw("block", 5s));
}

TEST_F(DdsShell, ABindingWhosePortsDifferFromItsCoresDeclarationIsRefusedAtConfigure) {
  binding.declare_all = false;
  start();
  shell->join();
  shell.reset();
  EXPECT_EQ(exit_code, 1);
  EXPECT_NE(log_text.str().find("wired, not declared: out rt/dh/command"), std::string::npos) << log_text.str();
  EXPECT_NE(log_text.str().find("configure failed"), std::string::npos) << log_text.str();
}

TEST_F(DdsShell, ASampleReachesItsLaneAndOneOfNoLaneTheBindingsOwnHandler) {
  start_lanes();
  ASSERT_TRUE(matched("first", 0, "lane0:first")) << log_text.str();
  send("second", 1);
  send("third", 7);
  EXPECT_TRUE(saw("lane1:second", 5s));
  EXPECT_TRUE(saw("loop:third", 5s));
  std::lock_guard l(m);
  EXPECT_EQ(std::count(echoed.begin(), echoed.end(), "lane0:second"), 0) << "a sample reached another lane";
}

TEST_F(DdsShell, AHeldLaneCostsTheProcessItsLivelinessWhileTheOtherLaneGoesOn) {
  start_lanes();
  ASSERT_TRUE(matched("first", 0, "lane0:first")) << log_text.str();
  send("block", 1);
  send("meanwhile", 0);
  EXPECT_TRUE(saw("lane0:meanwhile", 1s)) << "lane 0 waited for lane 1";
  {
    std::lock_guard l(m);
    EXPECT_EQ(std::count(echoed.begin(), echoed.end(), "lane1:block"), 0);
  }
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return lost > 0; })) << "a stuck lane kept the liveliness";
  EXPECT_TRUE(saw("lane1:block", 5s));
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return regained > 0; }));
}

TEST_F(DdsShell, ALanesExceptionEndsTheProcessWithItAsTheReason) {
  start_lanes();
  ASSERT_TRUE(matched("first", 0, "lane0:first")) << log_text.str();
  send("throw", 1);
  shell->join();
  shell.reset();
  EXPECT_EQ(exit_code, 1);
  EXPECT_NE(log_text.str().find("lane 1 was told to fail"), std::string::npos) << log_text.str();
}

}  // namespace
}  // namespace dh
