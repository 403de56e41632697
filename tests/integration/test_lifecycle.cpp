// The capability host's lifecycle over DDS, with a real host process serving a skill that can block it
// (fixtures/cap_stuck.cpp): its liveliness is asserted from its event loop, so a loop stuck in a skill
// loses the lease while the process lives, and gets it back when the loop runs again; and a stopping
// host announces that it drains, so the governor (registry, test_grounding.cpp) sends it nothing new. And
// the governor's readiness: an episode waits for the capabilities it may use to announce, not for a
// fixed time.
#include <signal.h>

#include <fstream>

#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "episode_request.hpp"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;

namespace {

constexpr std::uint32_t kChannel = 7;

struct Lifecycle : ::testing::Test {
  itest::IsolatedEnv env;
  std::unique_ptr<cli::Deployment> host;
  dds::Participant p{"itest"};
  std::mutex m;
  std::condition_variable cv;
  std::vector<msg::CapabilityAnnounce> announced;
  std::vector<msg::CommandStatus> statuses;
  int lost = 0, regained = 0;
  dds::Reader<msg::CapabilityAnnouncePubSubType> ann{p, topics::kAnnounce, dds::Qos::Announce,
      {[this](const msg::CapabilityAnnounce& a, const auto&) { std::lock_guard l(m); announced.push_back(a); cv.notify_all(); },
       [this](const dds::fdds::LivelinessChangedStatus& s) {
         std::lock_guard l(m);
         if (s.not_alive_count_change > 0) ++lost;
         if (s.alive_count_change > 0 && lost > 0) ++regained;  // alive again after it was lost
         cv.notify_all();
       },
       {}}};
  dds::Reader<msg::CommandStatusPubSubType> status{p, topics::kCommandStatus, dds::Qos::Status,
      {[this](const msg::CommandStatus& s, const auto&) { std::lock_guard l(m); statuses.push_back(s); cv.notify_all(); }, {}, {}}};
  std::optional<std::uint32_t> answered;  ///< the last step an action answered
  dds::Reader<msg::ActionPubSubType> actions{p, topics::kAction, dds::Qos::Action,
      {[this](const msg::Action& a, const auto&) { std::lock_guard l(m); answered = a.step(); cv.notify_all(); }, {}, {}}};
  dds::Writer<msg::CommandPubSubType> command{p, topics::kCommand, dds::Qos::Command};
  dds::Writer<msg::ObservationPubSubType> observation{p, topics::kObservation, dds::Qos::Observation};

  /// Starts cap_stuck with θ {block_ms, steps} and waits for its announcement.
  void start_host(int block_ms, int steps) {
    const auto library = env.runs / "stuck.yaml";
    std::ofstream(library) << "capability: stuck\nversion: \"1\"\narguments: []\npreconditions: []\n"
                           << "parameters: {block_ms: " << block_ms << ", steps: " << steps << "}\n"
                           << "ranges:\n  block_ms: {unit: \"1\", min: 0, max: 100000, what: \"milliseconds the "
                              "fixture's skill blocks its host's loop\"}\n"
                           << "  steps: {unit: steps, min: 1, max: 100000, what: \"steps the fixture's command runs\"}\n";
    host = std::make_unique<cli::Deployment>(
        std::vector<cli::ServiceSpec>{itest::service("cap_stuck", {"--library", library.string(), "--drain-timeout-s", "20"})},
        paths::bin_dir(), env.runs / "logs");
    ASSERT_TRUE(itest::wait_until(m, cv, 20s, [&] { return !announced.empty(); })) << "cap_stuck never announced";
    for (int i = 0; i < 200 && !(command.matched() && observation.matched()); ++i) std::this_thread::sleep_for(50ms);
    ASSERT_TRUE(command.matched() && observation.matched());
  }

  void send_command(const std::string& episode) {
    msg::Command c;
    c.channel(kChannel);
    c.episode_id(episode);
    c.command_id(episode + "/c0");
    c.kind(msg::COMMAND_START);
    c.capability("stuck");
    c.instance(announced.front().instance());
    c.theta(announced.front().parameters());
    c.start_step(0);
    c.budget_steps(2000);
    c.lease_until_step(10);
    c.grounding("state");
    c.decision_period(10);
    command.write(c);
    Observation o;
    o.budget_steps = 2000;
    observation.write(convert::to_msg(o, kChannel, episode));
  }
};

}  // namespace

TEST_F(Lifecycle, ALoopStuckInASkillLosesItsLivelinessWhileTheProcessLives) {
  start_host(3000, 2);
  // Idle, the loop keeps its lease: nothing lost over twice the lease.
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(2000 * dds::kLivelinessLeaseSec)));
  {
    std::lock_guard l(m);
    ASSERT_EQ(lost, 0) << "an idle host lost its liveliness";
  }
  send_command("stuck");
  EXPECT_TRUE(itest::wait_until(m, cv, 3s, [&] { return lost > 0; })) << "the stuck loop kept its lease";
  EXPECT_TRUE(host->exited().empty()) << "the process is alive: only its loop is stuck";
  EXPECT_TRUE(itest::wait_until(m, cv, 6s, [&] { return regained > 0; })) << "the loop ran again but stayed lost";
}

TEST_F(Lifecycle, AStoppingHostAnnouncesThatItDrainsAndFinishesItsCommand) {
  start_host(0, 40);
  send_command("drain");
  ASSERT_TRUE(itest::wait_until(m, cv, 5s, [&] {
    return std::any_of(statuses.begin(), statuses.end(), [](const auto& s) { return s.state() == msg::STATE_RUNNING; });
  })) << "the command never ran";
  ASSERT_TRUE(host->signal("cap_stuck", SIGTERM));
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] {
    return std::any_of(announced.begin(), announced.end(), [](const auto& a) { return a.draining(); });
  })) << "no draining announcement";
  EXPECT_TRUE(host->exited().empty()) << "it waits for its running command";
  // The command goes on: lock-step, as the seam runs it (the next observation once the step is
  // answered), it completes, then the host exits.
  for (std::uint32_t step = 1; step <= 45; ++step) {
    if (!itest::wait_until(m, cv, 2s, [&] { return answered && *answered + 1 >= step; })) break;
    Observation o;
    o.step = step;
    o.budget_steps = 2000;
    observation.write(convert::to_msg(o, kChannel, "drain"));
  }
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] {
    return std::any_of(statuses.begin(), statuses.end(), [](const auto& s) { return s.state() == msg::STATE_COMPLETED; });
  })) << "the running command did not finish while draining; last status "
       << (statuses.empty() ? std::string("none") : std::to_string(statuses.back().state()) + " " + statuses.back().reason());
  std::vector<std::string> gone;  // exited() names each service once, when it reaps it
  for (int i = 0; i < 100 && gone.empty(); ++i) {
    gone = host->exited();
    if (gone.empty()) std::this_thread::sleep_for(50ms);
  }
  EXPECT_EQ(gone, std::vector<std::string>{"cap_stuck"}) << "the host did not exit after its command";
}

namespace {

/// "put the bowl on the plate" with a library of pick_place alone (θ from configs/library).
msg::EpisodeRequest pick_place_only(std::uint32_t channel, const std::string& id) {
  msg::EpisodeRequest r = itest::bowl_on_plate(channel, id);
  const ConfigNode params = ConfigNode::load_file(paths::config_dir() / "library" / "pick_place.yaml").child("parameters");
  std::vector<msg::Param> theta;
  for (const auto& k : params.keys()) {
    msg::Param p;
    p.name(k);
    p.value(params.get<double>(k));
    theta.push_back(p);
  }
  msg::CapabilityTheta c;
  c.capability("pick_place");
  c.parameters(theta);
  r.library({c});
  r.library_version("pick-place-only");
  return r;
}

}  // namespace

// The governor is up long before pick_place announces itself; the request waits for it (the ready timeout
// is far longer than the test), the episode then runs and succeeds: readiness is announced, not assumed.
// A second governor whose episode's capability never comes starts it at its timeout and says so.
TEST(Readiness, AnEpisodeWaitsForItsCapabilitiesToAnnounceNotForAFixedTime) {
  itest::IsolatedEnv env;
  cli::Deployment core({itest::service("sim_worker", {"--channels", "2"}), itest::service("planner"),
                        itest::service("governor", {"--ready-timeout-ms", "120000"})},
                       paths::bin_dir(), env.runs / "logs");
  dds::Participant p("itest");
  std::mutex m;
  std::condition_variable cv;
  std::optional<msg::ChannelStatus> status;
  std::map<std::string, msg::EpisodeResult> results;
  dds::Reader<msg::ChannelStatusPubSubType> ch(p, topics::kChannelStatus, dds::Qos::ChannelStatus,
      {[&](const msg::ChannelStatus& s, const auto&) { std::lock_guard l(m); status = s; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::EpisodeResultPubSubType> res(p, topics::kEpisodeResult, dds::Qos::Episode,
      {[&](const msg::EpisodeResult& r, const auto&) { std::lock_guard l(m); results[r.episode_id()] = r; cv.notify_all(); }, {}, {}});
  dds::Writer<msg::EpisodeRequestPubSubType> req(p, topics::kEpisodeRequest, dds::Qos::Episode);
  ASSERT_TRUE(itest::wait_until(m, cv, 20s, [&] { return status && status->state() == msg::CHANNEL_IDLE; }));
  for (int i = 0; i < 400 && req.matched() < 2; ++i) std::this_thread::sleep_for(50ms);  // matching notifies nobody
  ASSERT_GE(req.matched(), 2u);
  req.write(pick_place_only(0, "waits"));
  std::this_thread::sleep_for(2s);
  {
    std::lock_guard l(m);
    ASSERT_TRUE(results.empty()) << "the episode ended before its capability existed";
  }
  cli::Deployment capability({itest::service("cap_pick_place")}, paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(itest::wait_until(m, cv, 60s, [&] { return results.count("waits") > 0; })) << "the held episode never ran";
  const msg::EpisodeResult r = results.at("waits");
  EXPECT_TRUE(r.success()) << r.reason();
  for (const auto& e : read_evidence(r.evidence_path())) {
    EXPECT_NE(e["kind"], "capabilities_missing") << e.dump();
    EXPECT_NE(e["kind"], "refusal") << e.dump();
  }

  // Another governor, whose episodes wait at most 4 s after its start: pick_place, running, is found within
  // that even on a loaded machine (1 s once lost the race to its discovery), push never announces, so the
  // episode starts at the timeout and its evidence names what was missing. (It takes channel 1: the request topic keeps the
  // first episode's request for channel 0, which the new governor may run again.)
  core.signal("governor", SIGTERM);
  for (int i = 0; i < 100 && core.exited().empty(); ++i) std::this_thread::sleep_for(50ms);
  cli::Deployment impatient({itest::service("governor", {"--ready-timeout-ms", "4000"})}, paths::bin_dir(),
                            env.runs / "logs");
  msg::EpisodeRequest with_push = pick_place_only(1, "missing");
  auto lib = with_push.library();
  lib.push_back(lib.front());
  lib.back().capability("push");
  with_push.library(lib);
  std::this_thread::sleep_for(300ms);
  req.write(with_push);
  ASSERT_TRUE(itest::wait_until(m, cv, 60s, [&] { return results.count("missing") > 0; }));
  bool named = false;
  for (const auto& e : read_evidence(results.at("missing").evidence_path()))
    named |= e["kind"] == "capabilities_missing" && e["missing"] == nlohmann::json::array({"push"});
  EXPECT_TRUE(named) << "the evidence does not say push was missing";
}

}  // namespace dh

namespace dh {
using namespace std::chrono_literals;
namespace {

using itest::read_text;

}  // namespace

// Every service runs through the managed lifecycle (common/lifecycle.hpp): a stop takes it through drain,
// deactivate and shutdown in order, and a transition that fails (here configure, on a malformed
// configuration) ends the process with the reason, after shutting down what it had made.
TEST(ManagedLifecycle, AFailedTransitionEndsTheServiceWithItsReasonAndAStopRunsEveryTransition) {
  itest::IsolatedEnv env;
  const auto bad = env.runs / "governor.yaml";
  std::ofstream(bad) << "decision_period: [10\n";
  cli::Deployment broken({itest::service("governor", {"--config", bad.string()})}, paths::bin_dir(), env.runs / "logs");
  std::vector<std::string> gone;
  for (int i = 0; i < 200 && gone.empty(); ++i) {
    gone = broken.exited();
    if (gone.empty()) std::this_thread::sleep_for(50ms);
  }
  EXPECT_EQ(gone, std::vector<std::string>{"governor"}) << "a governor without a configuration kept running";
  const std::string failed = read_text(env.runs / "logs" / "governor.log");
  EXPECT_NE(failed.find("lifecycle: configure failed in state unconfigured: "), std::string::npos) << failed;
  EXPECT_NE(failed.find(bad.string()), std::string::npos) << "the reason names the file:\n" << failed;
  EXPECT_EQ(failed.find("lifecycle: activate"), std::string::npos) << failed;
  EXPECT_NE(failed.find("lifecycle: shutdown (unconfigured -> finalized)"), std::string::npos) << failed;

  cli::Deployment planner({itest::service("planner")}, paths::bin_dir(), env.runs / "logs");
  const auto log = env.runs / "logs" / "planner.log";
  for (int i = 0; i < 200 && read_text(log).find("lifecycle: activate (inactive -> active)") == std::string::npos; ++i)
    std::this_thread::sleep_for(50ms);
  planner.stop();
  const std::string text = read_text(log);
  std::size_t at = 0;
  for (const char* line : {"lifecycle: configure (unconfigured -> inactive)", "lifecycle: activate (inactive -> active)",
                           "lifecycle: drain (active -> draining)", "lifecycle: deactivate (draining -> inactive)",
                           "lifecycle: shutdown (inactive -> finalized)"}) {
    const std::size_t found = text.find(line, at);
    ASSERT_NE(found, std::string::npos) << "missing, or out of order: " << line << "\n" << text;
    at = found;
  }
}

}  // namespace dh
