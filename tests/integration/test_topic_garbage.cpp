// Garbage and out-of-order samples on the topics, from a participant that is not part of the deployment:
// each is rejected and recorded where it lands, no process crashes, and the running episode goes on.
#include <fstream>
#include <nlohmann/json.hpp>

#include "dh/common/command.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "episode_request.hpp"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;

namespace {

std::vector<nlohmann::json> evidence_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<nlohmann::json> out;
  for (std::string line; std::getline(in, line);) out.push_back(nlohmann::json::parse(line));
  return out;
}

}  // namespace

// The simulator answers an episode request with its first observation, which may reach the governor
// before the request itself does; the governor keeps it and starts the episode.
TEST(TopicGarbage, AnObservationArrivingBeforeItsRequestStillStartsTheEpisode) {
  itest::IsolatedEnv env;
  cli::Deployment d({itest::service("governor")}, paths::bin_dir(), env.runs / "logs");
  dds::Participant p("itest");
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::string> plan_requests;
  dds::Reader<msg::PlanRequestPubSubType> plans(p, topics::kPlanRequest, dds::Qos::Planner,
      {[&](const msg::PlanRequest& r, const auto&) { std::lock_guard l(m); plan_requests.push_back(r.episode_id()); cv.notify_all(); }, {}, {}});
  dds::Writer<msg::EpisodeRequestPubSubType> req(p, topics::kEpisodeRequest, dds::Qos::Episode);
  dds::Writer<msg::ObservationPubSubType> obs(p, topics::kObservation, dds::Qos::Observation);
  // Matching raises no sample, so poll for it.
  for (int i = 0; i < 400 && !(req.matched() >= 1 && obs.matched() >= 1 && plans.matched() >= 1); ++i)
    std::this_thread::sleep_for(50ms);
  ASSERT_TRUE(req.matched() >= 1 && obs.matched() >= 1 && plans.matched() >= 1) << "the governor never appeared";
  msg::Observation o;
  o.channel(3);
  o.episode_id("early");
  o.step(0);
  o.budget_steps(300);
  o.gripper_opening(0.08);
  obs.write(o);
  std::this_thread::sleep_for(500ms);  // the observation is surely in before the request
  req.write(itest::bowl_on_plate(3, "early"));
  EXPECT_TRUE(itest::wait_until(m, cv, 10s, [&] { return !plan_requests.empty(); }))
      << "the governor dropped the early observation and waits for another";
  std::lock_guard l(m);
  ASSERT_FALSE(plan_requests.empty());
  EXPECT_EQ(plan_requests.front(), "early");
}

TEST(TopicGarbage, ForeignCommandsAndActionsForMissingChannelsAreRejectedAndRecorded) {
  itest::IsolatedEnv env;
  std::vector<cli::ServiceSpec> services;
  for (const auto& s : cli::load_launch_file(paths::home() / "deploy" / "local.yaml"))
    if (s.name != "cap_vla_act") services.push_back(s);
  cli::Deployment d(services, paths::bin_dir(), env.runs / "logs");
  dds::Participant p("itest");
  std::mutex m;
  std::condition_variable cv;
  bool idle = false, announced = false;
  std::uint32_t step = 0;
  std::optional<msg::EpisodeResult> result;
  std::vector<msg::SeamEvent> seam;
  dds::Reader<msg::CapabilityAnnouncePubSubType> ann(p, topics::kAnnounce, dds::Qos::Announce,
      {[&](const msg::CapabilityAnnounce& a, const auto&) { std::lock_guard l(m); announced |= a.capability() == "pick_place"; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::ChannelStatusPubSubType> ch(p, topics::kChannelStatus, dds::Qos::ChannelStatus,
      {[&](const msg::ChannelStatus& s, const auto&) { std::lock_guard l(m); idle |= s.state() == msg::CHANNEL_IDLE; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::ObservationPubSubType> obs(p, topics::kObservation, dds::Qos::Observation,
      {[&](const msg::Observation& o, const auto&) { std::lock_guard l(m); if (o.episode_id() == "garbage") step = o.step(); cv.notify_all(); }, {}, {}});
  dds::Reader<msg::EpisodeResultPubSubType> res(p, topics::kEpisodeResult, dds::Qos::Episode,
      {[&](const msg::EpisodeResult& r, const auto&) { std::lock_guard l(m); if (r.episode_id() == "garbage") result = r; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::SeamEventPubSubType> events(p, topics::kSeamEvent, dds::Qos::Status,
      {[&](const msg::SeamEvent& e, const auto&) { std::lock_guard l(m); seam.push_back(e); cv.notify_all(); }, {}, {}});
  dds::Writer<msg::EpisodeRequestPubSubType> req(p, topics::kEpisodeRequest, dds::Qos::Episode);
  dds::Writer<msg::CommandPubSubType> command(p, topics::kCommand, dds::Qos::Command);
  dds::Writer<msg::ActionPubSubType> action(p, topics::kAction, dds::Qos::Action);
  dds::Writer<msg::LeasePubSubType> lease(p, topics::kLease, dds::Qos::Lease);
  ASSERT_TRUE(itest::wait_until(m, cv, 20s, [&] { return announced && idle && req.matched() >= 2; }));
  std::this_thread::sleep_for(300ms);
  req.write(itest::bowl_on_plate(0, "garbage"));
  ASSERT_TRUE(itest::wait_until(m, cv, 20s, [&] { return step >= 20; })) << "the episode never got going";

  msg::Command foreign;
  foreign.channel(0);
  foreign.episode_id("garbage");
  foreign.command_id("intruder/c0");
  foreign.kind(msg::COMMAND_START);
  foreign.capability("teleport");
  foreign.budget_steps(1000000);
  command.write(foreign);
  msg::Action stray;
  stray.channel(77);
  stray.episode_id("garbage");
  stray.command_id("intruder/c0");
  stray.step(step);
  stray.a({1e9, -1e9, 0, 0, 0, 0, 1});
  action.write(stray);
  msg::Lease stray_lease;
  stray_lease.channel(78);
  stray_lease.episode_id("garbage");
  stray_lease.command_id("intruder/c0");
  stray_lease.valid_until_step(1000000);
  lease.write(stray_lease);

  ASSERT_TRUE(itest::wait_until(m, cv, 60s, [&] { return result.has_value(); })) << "the episode hung";
  EXPECT_TRUE(result->success()) << to_string(static_cast<Outcome>(result->outcome())) << ": " << result->reason();
  {
    std::lock_guard l(m);
    std::set<std::uint32_t> rejected;
    for (const auto& e : seam)
      if (e.kind() == msg::SEAM_REJECTED_CHANNEL) {
        rejected.insert(e.channel());
        EXPECT_NE(e.reason().find("which no simulator worker serves"), std::string::npos) << e.reason();
      }
    EXPECT_EQ(rejected, (std::set<std::uint32_t>{77, 78})) << "the stray action and lease are recorded";
  }
  const auto recs = evidence_of(result->evidence_path());
  const auto foreign_rec = std::find_if(recs.begin(), recs.end(), [](const auto& r) { return r["kind"] == "foreign_command"; });
  ASSERT_NE(foreign_rec, recs.end()) << "the governor recorded the foreign command in the episode's evidence";
  const std::string reason = (*foreign_rec)["reason"];
  EXPECT_NE(reason.find("'teleport' was not issued by this governor; no such capability is announced"), std::string::npos)
      << reason;
  EXPECT_TRUE(d.exited().empty()) << "a service died on garbage";
}

}  // namespace dh
