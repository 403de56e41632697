// The governor core's rules around episode requests, readiness, leases and liveliness, without DDS: what
// its shell and the in-process bus both rely on.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "dh/common/evidence.hpp"
#include "dh/gov/core.hpp"
#include "fixtures.hpp"

using namespace dh;
using namespace dh::gov;
using namespace std::chrono_literals;

namespace {

struct Core : ::testing::Test {
  std::filesystem::path runs = std::filesystem::temp_directory_path() /
                               ("dh_core_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
  Clock::time_point t0 = Clock::time_point{} + 1000s;
  std::map<std::string, ArmSpec> arms{{"full", {"full", "full", {}, true, "state"}},
                                      {"perceiving", {"perceiving", "full", {}, true, "perception"}}};
  std::unique_ptr<GovernorCore> core;

  void SetUp() override { make(t0 + 3s); }
  void TearDown() override { std::filesystem::remove_all(runs); }
  void make(Clock::time_point ready_by, std::optional<Clock::duration> rewrite = 250ms) {
    GovernorConfig config;
    config.mode = ExecutorMode::Full;
    core = std::make_unique<GovernorCore>(config, arms, CoreSettings{runs, ready_by, rewrite});
  }
  static EpisodeRequest request(const std::string& episode, std::uint32_t channel = 0) {
    EpisodeRequest r;
    r.channel = channel;
    r.episode_id = episode;
    r.instruction = "put the bowl on the plate";
    r.suite = "goal";
    r.cell = "goal";
    r.budget_steps = 300;
    r.library_version = "lib-test";
    r.library = {{"pick_place", {{"corridor_height", 0.16}}}};
    return r;
  }
  static Observation first(const std::string& episode, std::uint32_t channel = 0) {
    Observation o = test::scene_observation(0);
    o.channel = channel;
    o.episode_id = episode;
    return o;
  }
  static const ChannelEffects* find(const CoreEffects& fx, bool (*what)(const Effects&)) {
    const auto it = std::find_if(fx.begin(), fx.end(), [&](const ChannelEffects& e) { return what(e.fx); });
    return it == fx.end() ? nullptr : &*it;
  }
  static bool plans(const Effects& e) { return e.plan_request.has_value(); }
  static bool ends(const Effects& e) { return e.end.has_value(); }
  static bool leases(const Effects& e) { return e.lease.has_value(); }
  std::vector<std::string> kinds(const std::string& episode) {
    std::vector<std::string> k;
    for (const auto& r : read_evidence(runs / "evidence" / (episode + ".jsonl"))) k.push_back(r["kind"]);
    return k;
  }
  /// Runs "ep" up to its dispatch: returns the command's effects.
  ChannelEffects dispatched() {
    core->on_request(request("ep"), t0);
    const CoreEffects planned = core->on_observation(first("ep"), t0);
    const ChannelEffects* p = find(planned, plans);
    EXPECT_NE(p, nullptr);
    Advice a{p->fx.plan_request->request_id, false, "pick_place", {{"object", "bowl"}, {"target", "plate"}}, "", "",
             "rules", false, {}};
    const CoreEffects fx = core->on_advice(0, "ep", a, t0);
    EXPECT_EQ(fx.size(), 1u);
    EXPECT_TRUE(fx.at(0).fx.command);
    return fx.at(0);
  }
};

TEST_F(Core, ARequestWaitsForItsCapabilitiesAndStartsWhenTheyAnnounceWithoutASleep) {
  EXPECT_TRUE(core->on_request(request("ep"), t0).empty());
  EXPECT_FALSE(core->deadline(0)) << "held: no episode runs yet";
  EXPECT_TRUE(core->on_tick(t0 + 100ms).empty());
  EXPECT_FALSE(core->deadline(0));
  core->on_announce(test::pick_place_info());
  core->on_tick(t0 + 150ms);
  ASSERT_TRUE(core->deadline(0)) << "announced: the held request starts on the next tick";
  const auto k = kinds("ep");
  EXPECT_EQ(k.at(0), "episode_request");
  EXPECT_EQ(k.at(1), "episode_start");
  EXPECT_EQ(std::count(k.begin(), k.end(), "capabilities_missing"), 0);
}

TEST_F(Core, AfterTheReadyTimeAnEpisodeStartsWithoutAndSaysWhatWasMissing) {
  core->on_request(request("ep"), t0);
  core->on_tick(t0 + 3s);
  ASSERT_TRUE(core->deadline(0));
  const auto k = kinds("ep");
  EXPECT_EQ(std::count(k.begin(), k.end(), "capabilities_missing"), 1);
}

TEST_F(Core, AnObservationBeforeItsRequestIsKeptAndSeenWhenTheRequestComes) {
  core->on_announce(test::pick_place_info());
  EXPECT_TRUE(core->on_observation(first("ep"), t0).empty());
  const CoreEffects fx = core->on_request(request("ep"), t0);
  const ChannelEffects* p = find(fx, plans);
  ASSERT_NE(p, nullptr) << "the kept first observation starts planning";
  EXPECT_EQ(p->episode_id, "ep");
}

TEST_F(Core, ABusyChannelRefusesAnotherEpisodeAndIgnoresARedelivery) {
  core->on_announce(test::pick_place_info());
  core->on_request(request("ep"), t0);
  EXPECT_TRUE(core->on_request(request("ep"), t0).empty()) << "redelivery";
  const CoreEffects fx = core->on_request(request("other"), t0);
  ASSERT_EQ(fx.size(), 1u);
  ASSERT_TRUE(fx[0].fx.end);
  EXPECT_EQ(fx[0].episode_id, "other");
  EXPECT_EQ(fx[0].fx.end->outcome, Outcome::Rejected);
  EXPECT_NE(fx[0].fx.end->reason.find("busy with episode ep"), std::string::npos) << fx[0].fx.end->reason;
  EXPECT_TRUE(core->deadline(0)) << "the running episode goes on";
  EXPECT_TRUE(core->on_request(request("other"), t0).empty()) << "a refused request redelivered is not answered twice";
}

TEST_F(Core, ARequestItsArmCannotRunIsRefusedAtOnceWithItsEvidence) {
  EpisodeRequest r = request("ep");
  r.arm = "perceiving";  // grounds from perception, but the request does not say so
  const CoreEffects fx = core->on_request(r, t0);
  const ChannelEffects* e = find(fx, ends);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->fx.end->outcome, Outcome::Rejected);
  EXPECT_NE(e->fx.end->reason.find("grounding: perception"), std::string::npos) << e->fx.end->reason;
  EXPECT_EQ(e->evidence, runs / "evidence" / "ep.jsonl");
  EXPECT_EQ(kinds("ep"), (std::vector<std::string>{"episode_request", "episode_rejected"}));
  r.arm = "nonesuch";
  r.episode_id = "ep2";
  const ChannelEffects* u = find(core->on_request(r, t0), ends);
  ASSERT_NE(u, nullptr);
  EXPECT_NE(u->fx.end->reason.find("nonesuch"), std::string::npos) << u->fx.end->reason;
}

TEST_F(Core, TheRunningLeaseIsProducedAgainOnlyAfterTheRewriteInterval) {
  core->on_announce(test::pick_place_info());
  const ChannelEffects d = dispatched();
  ASSERT_TRUE(d.fx.lease);
  EXPECT_EQ(find(core->on_tick(t0 + 200ms), leases), nullptr);
  const ChannelEffects* again = find(core->on_tick(t0 + 250ms), leases);
  ASSERT_NE(again, nullptr);
  EXPECT_EQ(again->fx.lease->command_id, d.fx.command->command_id);
  EXPECT_EQ(again->fx.lease->valid_until_step, d.fx.lease->valid_until_step);
  EXPECT_EQ(find(core->on_tick(t0 + 300ms), leases), nullptr);

  make(t0 + 3s, std::nullopt);  // the in-process bus: no keep-alive
  core->on_announce(test::pick_place_info());
  dispatched();
  EXPECT_EQ(find(core->on_tick(t0 + 1s), leases), nullptr);
}

TEST_F(Core, ALostInstanceEndsItsCommandAndTheCancelNamesTheInstance) {
  core->on_announce(test::pick_place_info("pick_place@a"));
  const ChannelEffects d = dispatched();
  EXPECT_EQ(d.fx.command->instance, "pick_place@a");
  const CoreEffects fx = core->on_liveliness("pick_place@a", false, t0 + 10ms);
  ASSERT_FALSE(fx.empty());
  EXPECT_FALSE(core->registry().alive("pick_place@a"));
  const auto k = kinds("ep");
  EXPECT_NE(std::find(k.begin(), k.end(), "capability_lost"), k.end());
  // The lost command is cancelled at the instance it was dispatched to.
  const auto cancel = std::find_if(fx.begin(), fx.end(), [](const ChannelEffects& e) { return e.fx.cancel_command.has_value(); });
  ASSERT_NE(cancel, fx.end()) << "no cancel for the lost command";
  EXPECT_EQ(*cancel->fx.cancel_command, d.fx.command->command_id);
  EXPECT_EQ(cancel->cancel_instance, "pick_place@a");
}

TEST_F(Core, AForeignCommandIsRecordedInTheRunningEpisodeAndNotObeyed) {
  core->on_announce(test::pick_place_info());
  core->on_request(request("ep"), t0);
  const std::string why = core->on_foreign_command(0, "ep", "x/c9", "fly");
  EXPECT_NE(why.find("not issued by this governor"), std::string::npos);
  EXPECT_NE(why.find("no such capability"), std::string::npos);
  const auto k = kinds("ep");
  EXPECT_NE(std::find(k.begin(), k.end(), "foreign_command"), k.end());
}

TEST_F(Core, AForgottenChannelTakesTheNextEpisode) {
  core->on_announce(test::pick_place_info());
  core->on_request(request("ep"), t0);
  core->forget(0);
  EXPECT_FALSE(core->deadline(0));
  core->on_request(request("next"), t0);
  EXPECT_TRUE(core->deadline(0));
}

}  // namespace

TEST_F(Core, ALiveViewGetsEachEpisodeAsItsEvidenceStandsAtMostOncePerDecisionPeriod) {
  core->on_announce(test::pick_place_info());
  dispatched();
  auto live = core->take_live();
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].episode_id, "ep");
  EXPECT_EQ(live[0].cell, "goal");
  EXPECT_EQ(live[0].budget_steps, 300u);
  EXPECT_EQ(live[0].capability, "pick_place");
  EXPECT_EQ(live[0].evidence, runs / "evidence" / "ep.jsonl");
  EXPECT_FALSE(live[0].ended);
  EXPECT_TRUE(core->take_live().empty()) << "nothing new since";
  // Steps between decisions are not news; the decision at step 10 is.
  for (std::uint32_t step = 1; step <= 10; ++step) {
    Observation o = first("ep");
    o.step = step;
    core->on_observation(o, t0 + step * 50ms);
    if (step < 10) {
      EXPECT_TRUE(core->take_live().empty()) << "step " << step;
    }
  }
  live = core->take_live();
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].step, 10u);
  EXPECT_EQ(live[0].decision, "continue");
  // A rejected request on another channel is news with its end.
  EpisodeRequest r = request("bad", 1);
  r.arm = "nonesuch";
  core->on_request(r, t0 + 1s);
  live = core->take_live();
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].channel, 1u);
  EXPECT_EQ(live[0].episode_id, "bad");
  EXPECT_TRUE(live[0].ended);
  EXPECT_EQ(live[0].outcome, "rejected");
  EXPECT_NE(live[0].reason.find("nonesuch"), std::string::npos) << live[0].reason;
}
