// The one DDS shell (dds_shell.hpp) over real DDS, with a test binding run in this process: samples reach
// their handler and the process's own samples of a kSkipOwn input do not; work posted from another thread
// is written from the loop; a loop held longer than its allowance loses the liveliness of its announcement
// and gets it back; a binding whose ports differ from its core's declaration is refused at configure, and
// the reason names the topic.
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
  void TearDown() override {
    request_shutdown();
    if (shell) shell->join();
  }
  void send(const std::string& id) {
    msg::Command c;
    c.command_id(id);
    commands->write(c);
  }
  bool saw(const std::string& id, std::chrono::milliseconds within) {
    return itest::wait_until(m, cv, within, [&] { return std::count(echoed.begin(), echoed.end(), id) > 0; });
  }
};

TEST_F(DdsShell, SamplesReachTheirHandlerOwnSamplesDoNotAndPostedWorkIsWrittenFromTheLoop) {
  start();
  ASSERT_TRUE(itest::wait_until(m, cv, 10s, [&] { return announced > 0; })) << "the binding never activated";
  // Writers and readers of the two participants match in their own time: send until one is echoed.
  for (int i = 0; i < 50 && !saw("first", 200ms); ++i) send("first");
  ASSERT_TRUE(saw("first", 0ms)) << log_text.str();
  send("post");
  EXPECT_TRUE(saw("post (posted)", 5s));
  std::lock_guard l(m);
  EXPECT_EQ(std::count(echoed.begin(), echoed.end(), "own"), 0) << "the shell delivered its own command back";
}

TEST_F(DdsShell, ALoopHeldLongerThanItsAllowanceLosesItsLivelinessAndGetsItBack) {
  start();
  ASSERT_TRUE(itest::wait_until(m, cv, 10s, [&] { return announced > 0; }));
  for (int i = 0; i < 50 && !saw("first", 200ms); ++i) send("first");
  ASSERT_TRUE(saw("first", 0ms));
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

}  // namespace
}  // namespace dh
