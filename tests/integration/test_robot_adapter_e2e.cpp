// The robot adapter as a process on real DDS, driving the RTDE test controller (a test double for the
// metal: the UR7e in MuJoCo, here in the test's own process so the test can read the arm and inject
// faults). The test stands in for the governor: it requests an episode on the arm's channel, grants a
// lease and sends actions. Then it goes silent as a killed governor does, or the controller makes a
// protective stop, or the link is cut; each time the arm stops and the channel says why.
#include <algorithm>
#include <cmath>
#include <optional>

#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/rtde/simulated_ur.hpp"
#include "episode_request.hpp"
#include "harness.hpp"

namespace dh {
namespace {

using namespace std::chrono_literals;

constexpr std::array<double, 6> kReady{0, -1.3, 1.6, -1.87, -1.5708, 0};

struct RobotAdapter : ::testing::Test {
  itest::IsolatedEnv env;
  rtde::SimulatedController arm{paths::config_dir() / "robots" / "ur7e.urdf", kReady};
  // The test double shares a loaded host (CI runs two tests at once): 2 s for its silence, not 500 ms.
  cli::Deployment adapter{
      {itest::service("robot_adapter", {"--rtde-port", std::to_string(arm.port()), "--script-port",
                                        std::to_string(arm.script_port()), "--channel", "0",
                                        "--abandon-after-s", "3", "--timeout-ms", "2000"})},
      paths::bin_dir(),
      env.runs / "logs"};
  dds::Participant p{"itest"};
  std::mutex m;
  std::condition_variable cv;
  std::optional<msg::ChannelStatus> status;
  std::optional<msg::Observation> last;
  std::vector<msg::SeamEvent> events;
  dds::Reader<msg::ChannelStatusPubSubType> ch{p,
                                               topics::kChannelStatus,
                                               dds::Qos::ChannelStatus,
                                               {[&](const msg::ChannelStatus& s, const auto&) {
                                                  std::lock_guard l(m);
                                                  status = s;
                                                  cv.notify_all();
                                                },
                                                {},
                                                {}}};
  dds::Reader<msg::ObservationPubSubType> obs{p,
                                              topics::kObservation,
                                              dds::Qos::Observation,
                                              {[&](const msg::Observation& o, const auto&) {
                                                 std::lock_guard l(m);
                                                 last = o;
                                                 cv.notify_all();
                                               },
                                               {},
                                               {}}};
  dds::Reader<msg::SeamEventPubSubType> seam{p,
                                             topics::kSeamEvent,
                                             dds::Qos::Status,
                                             {[&](const msg::SeamEvent& e, const auto&) {
                                                std::lock_guard l(m);
                                                events.push_back(e);
                                                cv.notify_all();
                                              },
                                              {},
                                              {}}};
  dds::Writer<msg::EpisodeRequestPubSubType> req{p, topics::kEpisodeRequest, dds::Qos::Episode};
  dds::Writer<msg::LeasePubSubType> lease{p, topics::kLease, dds::Qos::Lease};
  dds::Writer<msg::ActionPubSubType> act{p, topics::kAction, dds::Qos::Action};

  bool idle() { return status && status->state() == msg::CHANNEL_IDLE; }

  /// Requests `episode`, grants its one command a lease and drives `steps` actions; returns the tool's
  /// start and end positions.
  std::pair<std::array<double, 3>, std::array<double, 3>> drive(const std::string& episode,
                                                                std::uint32_t steps) {
    EXPECT_TRUE(itest::wait_until(m, cv, 20s, [&] {
      return idle() && req.matched() >= 1 && act.matched() >= 1 && lease.matched() >= 1;
    })) << "the adapter did not come up";
    req.write(itest::bowl_on_plate(0, episode));
    EXPECT_TRUE(itest::wait_until(
        m, cv, 10s, [&] { return last && last->episode_id() == episode && last->step() == 0; }));
    std::array<double, 3> start{}, end{};
    {
      std::lock_guard g(m);
      std::copy_n(last->ee().p().begin(), 3, start.begin());
    }
    msg::Lease l;
    l.channel(0);
    l.episode_id(episode);
    l.command_id("c0");
    l.valid_until_step(1000);
    l.budget_until_step(1000);
    lease.write(l);
    for (std::uint32_t t = 0; t < steps; ++t) {
      msg::Action a;
      a.channel(0);
      a.episode_id(episode);
      a.command_id("c0");
      a.step(t);
      a.a({0, 0.6, 0, 0, 0, 0, -1});
      act.write(a);
      EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return last->step() == t + 1; }))
          << "action " << t << " not applied";
    }
    std::lock_guard g(m);
    std::copy_n(last->ee().p().begin(), 3, end.begin());
    return {start, end};
  }

  double peak_over(std::chrono::milliseconds window) {
    arm.with_arm([](rtde::SimulatedUr& a) { a.reset_peak(); });
    std::this_thread::sleep_for(window);
    return arm.with_arm([](rtde::SimulatedUr& a) { return a.peak_speed(); });
  }
};

TEST_F(RobotAdapter, AGovernorThatFallsSilentMidEpisodeLeavesTheArmStoppedAndTheEpisodeAbandoned) {
  const auto [start, end] = drive("ur-silent", 15);
  // The tool went where the actions said: 15 steps × 0.6 × 0.0133 m along +y (servo.hpp).
  EXPECT_NEAR(end[1] - start[1], 15 * 0.6 * 0.05 * 0.2655, 0.03);
  EXPECT_NEAR(end[2], start[2], 0.01);
  // The governor is gone: no lease, no action. Within the program's watchdog the arm stops, and stays.
  std::this_thread::sleep_for(300ms);
  EXPECT_LT(peak_over(700ms), 1e-3) << "the arm moved after its governor went silent";
  ASSERT_TRUE(itest::wait_until(m, cv, 10s, [&] { return idle() && !status->last_error().empty(); }));
  EXPECT_NE(status->last_error().find("abandoned"), std::string::npos) << status->last_error();
  EXPECT_EQ(status->last_episode_id(), "ur-silent");
}

TEST_F(RobotAdapter, AProtectiveStopEndsTheEpisodeWithItsReason) {
  drive("ur-pstop", 4);
  arm.with_arm([](rtde::SimulatedUr& a) { a.protective_stop(); });
  msg::Action a;
  a.channel(0);
  a.episode_id("ur-pstop");
  a.command_id("c0");
  a.step(4);
  a.a({0, 0.6, 0, 0, 0, 0, -1});
  act.write(a);
  ASSERT_TRUE(
      itest::wait_until(m, cv, 10s, [&] { return idle() && status->last_episode_id() == "ur-pstop"; }));
  EXPECT_NE(status->last_error().find("protective stop"), std::string::npos) << status->last_error();
  {
    // The governor hears it as a code on the seam's topic, with the same reason.
    std::unique_lock l(m);
    ASSERT_TRUE(cv.wait_for(l, 5s, [&] {
      return std::any_of(events.begin(), events.end(),
                         [](const msg::SeamEvent& e) { return e.kind() == msg::SEAM_ENDED; });
    }));
    const auto e = std::find_if(events.begin(), events.end(),
                                [](const msg::SeamEvent& e) { return e.kind() == msg::SEAM_ENDED; });
    EXPECT_EQ(e->reason(), status->last_error());
    EXPECT_EQ(e->episode_id(), "ur-pstop");
  }
  std::this_thread::sleep_for(300ms);  // the stop's deceleration
  EXPECT_LT(peak_over(500ms), 1e-3);
}

TEST_F(RobotAdapter, ACutLinkIsRecordedTheArmStopsAndTheNextEpisodeReconnects) {
  drive("ur-cut", 4);
  arm.controller().drop_client();
  msg::Action a;
  a.channel(0);
  a.episode_id("ur-cut");
  a.command_id("c0");
  a.step(4);
  a.a({0, 0.6, 0, 0, 0, 0, -1});
  act.write(a);
  ASSERT_TRUE(itest::wait_until(m, cv, 10s, [&] { return idle() && status->last_episode_id() == "ur-cut"; }));
  EXPECT_NE(status->last_error().find("the link to the controller was lost"), std::string::npos)
      << status->last_error();
  std::this_thread::sleep_for(300ms);
  EXPECT_LT(peak_over(500ms), 1e-3);
  // The next episode sets the link up again.
  const auto [start, end] = drive("ur-after", 3);
  EXPECT_GT(end[1] - start[1], 0.01);
}

}  // namespace
}  // namespace dh
