// A capability process given a command with `grounding: perception` moves in the perception service's
// world, not among the observation's object poses: it checks the perceived sizes, waits for a fresh frame,
// and refuses what no frame has shown — all over DDS with a real cap_pick_place.
#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;

namespace {

constexpr std::uint32_t kChannel = 6;

struct PerceivedCommands : ::testing::Test {
  itest::IsolatedEnv env;
  cli::Deployment d{{itest::service("cap_pick_place")}, paths::bin_dir(), env.runs / "logs"};
  dds::Participant p{"itest"};
  std::mutex m;
  std::condition_variable cv;
  std::string instance;
  std::vector<msg::Param> theta;
  std::vector<msg::CommandStatus> statuses;
  std::vector<std::uint32_t> action_steps;
  dds::Reader<msg::CapabilityAnnouncePubSubType> ann{p, topics::kAnnounce, dds::Qos::Announce,
      {[this](const msg::CapabilityAnnounce& a, const auto&) {
         std::lock_guard l(m);
         instance = a.instance();
         theta = a.parameters();  // the library's θ, which a command carries as the governor's does
         cv.notify_all();
       }, {}, {}}};
  dds::Reader<msg::CommandStatusPubSubType> status{p, topics::kCommandStatus, dds::Qos::Status,
      {[this](const msg::CommandStatus& s, const auto&) { std::lock_guard l(m); statuses.push_back(s); cv.notify_all(); }, {}, {}}};
  dds::Reader<msg::ActionPubSubType> actions{p, topics::kAction, dds::Qos::Action,
      {[this](const msg::Action& a, const auto&) { std::lock_guard l(m); action_steps.push_back(a.step()); cv.notify_all(); }, {}, {}}};
  dds::Writer<msg::CommandPubSubType> command{p, topics::kCommand, dds::Qos::Command};
  dds::Writer<msg::ObservationPubSubType> observation{p, topics::kObservation, dds::Qos::Observation};
  dds::Writer<msg::SceneEstimatePubSubType> scene{p, topics::kSceneEstimate, dds::Qos::Observation};

  void SetUp() override {
    ASSERT_TRUE(itest::wait_until(m, cv, 20s, [&] { return !instance.empty(); })) << "cap_pick_place never announced";
    for (int i = 0; i < 200 && !(command.matched() && observation.matched() && scene.matched()); ++i)
      std::this_thread::sleep_for(50ms);  // matching raises no sample, so poll for it
    ASSERT_TRUE(command.matched() && observation.matched() && scene.matched());
  }

  /// The cell at `step`: the tool above the table, a 4 cm butter box and a plate where the simulator says.
  void observe(const std::string& episode, std::uint32_t step) {
    Observation o;
    o.step = step;
    o.budget_steps = 600;
    o.ee_p = {-0.1, 0.0, 0.25};
    o.ee_q = {0, 1, 0, 0};
    o.gripper_opening = 0.08;
    o.entities.assign(2, EntityState{});
    o.entities[0].name = "butter";
    o.entities[0].kind = "box";
    o.entities[0].p = {0.0, -0.15, 0.0};
    o.entities[0].half_extents = {0.02, 0.02, 0.02};
    o.entities[1].name = "plate";
    o.entities[1].kind = "plate";
    o.entities[1].p = {0.0, 0.15, 0.0};
    o.entities[1].half_extents = {0.09, 0.09, 0.006};
    observation.write(convert::to_msg(o, kChannel, episode));
  }

  /// A frame of `step` that saw the butter box `butter_width` m wide (none: not seen) and the plate.
  void perceive(const std::string& episode, std::uint32_t step, std::optional<double> butter_width) {
    msg::SceneEstimate e;
    e.channel(kChannel);
    e.episode_id(episode);
    e.step(step);
    e.camera("workcell");
    e.looked_for({"butter", "plate"});
    std::vector<msg::PerceivedEntity> seen(1);
    seen[0].entity("plate");
    seen[0].centroid({0.0, 0.15, 0.003});
    seen[0].size({0.18, 0.18, 0.006});
    seen[0].confidence(0.9);
    if (butter_width) {
      msg::PerceivedEntity b;
      b.entity("butter");
      b.centroid({0.01, -0.15, 0.02});
      b.size({*butter_width, *butter_width, 0.04});
      b.confidence(0.9);
      seen.push_back(b);
    }
    e.seen(seen);
    scene.write(e);
  }

  void start(const std::string& episode, const std::string& grounding, std::uint32_t step) {
    msg::Command c;
    c.channel(kChannel);
    c.episode_id(episode);
    c.command_id(episode + "/c0");
    c.kind(msg::COMMAND_START);
    c.capability("pick_place");
    c.instance(instance);
    std::vector<msg::Binding> args(2);
    args[0].role("object");
    args[0].entity("butter");
    args[1].role("target");
    args[1].entity("plate");
    c.args(args);
    c.theta(theta);
    c.start_step(step);
    c.budget_steps(500);
    c.lease_until_step(step + 20);
    c.grounding(grounding);
    c.perception(convert::to_msg(PerceptionLimits{}));  // the episode's limits, as the governor sends them
    c.decision_period(10);
    command.write(c);
  }

  /// The first status of `episode`'s command that is not RUNNING, within `timeout`.
  std::optional<msg::CommandStatus> outcome(const std::string& episode, std::chrono::milliseconds timeout) {
    std::optional<msg::CommandStatus> found;
    itest::wait_until(m, cv, timeout, [&] {
      for (const auto& s : statuses)
        if (s.episode_id() == episode && s.state() != msg::STATE_RUNNING) found = s;
      return found.has_value();
    });
    return found;
  }
};

TEST_F(PerceivedCommands, TheSkillChecksThePerceivedSizeNotTheSimulatorsOne) {
  observe("state", 0);
  start("state", "state", 0);
  auto s = outcome("state", 5s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_ACCEPTED) << s->reason() << ": the simulator's 4 cm box fits the jaw";

  perceive("wide", 0, 0.12);
  observe("wide", 0);
  start("wide", "perception", 0);
  s = outcome("wide", 5s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_REFUSED);
  EXPECT_NE(s->reason().find("'butter' is wider than the jaw opens"), std::string::npos) << s->reason();

  perceive("narrow", 0, 0.04);
  observe("narrow", 0);
  start("narrow", "perception", 0);
  s = outcome("narrow", 5s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_ACCEPTED) << s->reason();
}

TEST_F(PerceivedCommands, AStaleFrameHoldsTheCommandUntilAFreshOneComes) {
  perceive("stale", 0, 0.04);
  observe("stale", 40);
  start("stale", "perception", 40);
  EXPECT_FALSE(outcome("stale", 1s)) << "the frame of step 0 is 40 steps old: it waits";
  {
    std::lock_guard l(m);
    EXPECT_TRUE(action_steps.empty()) << "no action while waiting: the lock-stepped channel waits too";
  }
  perceive("stale", 40, 0.04);
  const auto s = outcome("stale", 5s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_ACCEPTED) << s->reason();
  EXPECT_TRUE(itest::wait_until(m, cv, 5s, [&] { return !action_steps.empty(); }));
}

TEST_F(PerceivedCommands, NoFrameOrAnUnseenObjectIsARefusalWithItsReason) {
  observe("none", 0);
  start("none", "perception", 0);
  auto s = outcome("none", 10s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_REFUSED);
  EXPECT_NE(s->reason().find("perception: no scene estimate from the perception service for this episode; waited "
                             "3000 ms for a fresh frame"),
            std::string::npos)
      << s->reason();

  perceive("unseen", 0, std::nullopt);
  observe("unseen", 0);
  start("unseen", "perception", 0);
  s = outcome("unseen", 5s);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state(), msg::STATE_REFUSED);
  EXPECT_NE(s->reason().find("perception has not seen 'butter' in this episode"), std::string::npos) << s->reason();
}

}  // namespace
}  // namespace dh
