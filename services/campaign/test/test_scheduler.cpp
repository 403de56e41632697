// Spreading episodes over channels: assignment, results, lost episodes, physics reports.
#include <gtest/gtest.h>

#include "dh/campaign/scheduler.hpp"

namespace dh::campaign {
namespace {

using namespace std::chrono_literals;

std::vector<EpisodeKey> keys(unsigned n) {
  std::vector<EpisodeKey> k;
  for (unsigned s = 1; s <= n; ++s) k.push_back({"full", "goal", 8, s});
  return k;
}

Scheduler make(unsigned n, unsigned reruns = 0) {
  SchedulerOptions o;
  o.reruns = reruns;
  o.run_tag = "r1";
  o.start_allowance = 10s;
  o.per_step_allowance = 100ms;  // budget 300 → deadline 40 s
  o.physics_wait = 2s;
  return Scheduler(keys(n), [](const EpisodeKey&) { return 300u; }, o);
}

TEST(Scheduler, IdleChannelsGetEpisodesInOrderAndResultsBecomeRecords) {
  auto s = make(3);
  const auto t0 = Clock::now();
  EXPECT_TRUE(s.assign(t0).empty()) << "no channel known yet";
  s.channel_status(4, "w1", true, "", 0, "", t0);
  s.channel_status(2, "w0", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].channel, 2u);
  EXPECT_EQ(d[0].key.seed, 1u);
  EXPECT_EQ(d[1].channel, 4u);
  EXPECT_EQ(d[1].key.seed, 2u);
  EXPECT_NE(d[0].episode_id, d[1].episode_id);
  EXPECT_NE(d[0].episode_id.find("full-goal-t8-s1-r1"), std::string::npos) << d[0].episode_id;
  EXPECT_TRUE(s.assign(t0).empty()) << "both channels are busy";
  EXPECT_EQ(s.pending(), 1u);

  s.result({d[0].episode_id, true, 170, Outcome::Success, "goal holds", "/e/1.jsonl", {"vla_act"}}, t0 + 3s);
  EXPECT_TRUE(s.take_finished(t0 + 3s).empty()) << "waits for the channel's physics report";
  s.channel_status(2, "w0", true, d[0].episode_id, 0.42, "", t0, {150, true});
  const auto recs = s.take_finished(t0 + 3s);
  ASSERT_EQ(recs.size(), 1u);
  const EpisodeRecord& r = recs[0];
  EXPECT_EQ(r.arm, "full");
  EXPECT_EQ(r.seed, 1u);
  EXPECT_TRUE(r.success);
  EXPECT_EQ(r.steps, 170u);
  EXPECT_EQ(r.budget, 300u);
  EXPECT_DOUBLE_EQ(r.wall_s, 3.0);
  EXPECT_DOUBLE_EQ(r.physics_s, 0.42);
  EXPECT_EQ(r.worker, "w0");
  EXPECT_EQ(r.channel, 2u);
  EXPECT_FALSE(r.infrastructure);
  EXPECT_EQ(r.evidence_path, "/e/1.jsonl");
  EXPECT_EQ(r.sim_success, true) << "the simulator's own verdict, from the channel's report";
  EXPECT_EQ(r.sim_goal_step, 150);
  EXPECT_TRUE(r.sim_goal_at_end);
  EXPECT_FALSE(r.verdict_disagrees());
  EXPECT_EQ(r.capabilities_missing, std::vector<std::string>{"vla_act"}) << "the arm ran without the policy";

  const auto d2 = s.assign(t0 + 3s);
  ASSERT_EQ(d2.size(), 1u);
  EXPECT_EQ(d2[0].channel, 2u);
  EXPECT_EQ(d2[0].key.seed, 3u);
}

TEST(Scheduler, AnIdleAnnouncementCrossingTheRequestDoesNotFreeTheChannel) {
  auto s = make(2);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 1u);
  s.channel_status(0, "w", true, "", 0, "", t0);  // sent before the channel saw our request
  EXPECT_TRUE(s.assign(t0).empty());
  s.result({d[0].episode_id, false, 300, Outcome::BudgetExhausted, "", "", {}}, t0 + 1s);
  EXPECT_TRUE(s.assign(t0 + 1s).empty()) << "free only once it says it is idle after the episode";
  s.channel_status(0, "w", true, d[0].episode_id, 0.1, "", t0);
  EXPECT_EQ(s.assign(t0 + 1s).size(), 1u);
  const auto recs = s.take_finished(t0 + 1s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_TRUE(recs[0].tick_limit);
}

TEST(Scheduler, AnIdleAnnouncementArrivingBeforeTheResultFreesTheChannelWithTheResult) {
  auto s = make(2);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  s.channel_status(0, "w", true, d[0].episode_id, 0.2, "", t0);  // the result is still on its way
  EXPECT_TRUE(s.assign(t0).empty());
  s.result({d[0].episode_id, true, 170, Outcome::Success, "", "", {}}, t0 + 1s);
  EXPECT_EQ(s.assign(t0 + 1s).size(), 1u);
  const auto recs = s.take_finished(t0 + 1s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_DOUBLE_EQ(recs[0].physics_s, 0.2);
}

TEST(Scheduler, AnEpisodeWithoutAResultBeforeItsDeadlineIsAnInfrastructureLoss) {
  auto s = make(2);
  const auto t0 = Clock::now();
  s.channel_status(7, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  s.expire(t0 + 39s);
  EXPECT_EQ(s.running(), 1u);
  s.expire(t0 + 41s);
  EXPECT_EQ(s.running(), 0u);
  const auto recs = s.take_finished(t0 + 41s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_TRUE(recs[0].infrastructure);
  EXPECT_FALSE(recs[0].success);
  EXPECT_EQ(recs[0].outcome, "infrastructure");
  EXPECT_NE(recs[0].reason.find("no result within 40 s on channel 7 (worker w)"), std::string::npos) << recs[0].reason;
  // A late result of the lost episode is ignored; the channel serves again once it says it is idle.
  s.result({d[0].episode_id, true, 100, Outcome::Success, "", "", {}}, t0 + 42s);
  EXPECT_TRUE(s.take_finished(t0 + 50s).empty());
  EXPECT_TRUE(s.assign(t0 + 42s).empty());
  s.channel_status(7, "w", true, d[0].episode_id, 0.3, "", t0);
  EXPECT_EQ(s.assign(t0 + 42s).size(), 1u);
  EXPECT_FALSE(s.done());
}

TEST(Scheduler, AnEpisodeTheSimulatorCannotStartEndsAtOnceWithItsReason) {
  auto s = make(2);
  const auto t0 = Clock::now();
  s.channel_status(3, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  s.channel_status(3, "w", true, d[0].episode_id, 0, "cannot place 'bowl' without overlap for seed 1", t0 + 1s);
  const auto recs = s.take_finished(t0 + 1s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_TRUE(recs[0].infrastructure);
  EXPECT_EQ(recs[0].reason, "simulator: cannot place 'bowl' without overlap for seed 1");
  EXPECT_FALSE(recs[0].sim_success.has_value()) << "a channel that could not run it has no verdict on it";
  // The governor still runs it until it misses the observation; it would reject a request for the channel.
  EXPECT_TRUE(s.assign(t0 + 2s).empty()) << "the governor has not ended it yet";
  s.result({d[0].episode_id, false, 0, Outcome::Infrastructure, "no first observation", "", {}}, t0 + 16s);
  EXPECT_EQ(s.assign(t0 + 16s).size(), 1u) << "the governor's result frees the channel";
}

// The simulator's physics failed mid-episode (seen with a perturbed library: MuJoCo's contact buffer
// overflowed): 32 of 200 episodes were lost as "channel 0 is busy" while the governor waited 10 s for
// the next observation. The channel now waits for the governor, or governor_release at most.
TEST(Scheduler, AChannelWhoseEpisodeTheSimulatorEndedWaitsForTheGovernorsResult) {
  auto s = make(3, 1);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 1u);
  s.channel_status(0, "w", true, d[0].episode_id, 0, "physics failed at step 242: contact buffer overflowed", t0 + 5s);
  ASSERT_EQ(s.take_losses().size(), 1u) << "the attempt is lost and runs again";
  for (auto t = t0 + 5s; t < t0 + 15s; t += 1s) EXPECT_TRUE(s.assign(t).empty()) << "no request the governor rejects";
  s.result({d[0].episode_id, false, 242, Outcome::Infrastructure, "no next observation", "", {}}, t0 + 15s);
  const auto again = s.assign(t0 + 15s);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(to_string(again[0].key), to_string(d[0].key)) << "the lost episode runs again first";
  // Without the governor's result the channel serves again after governor_release (30 s).
  s.result({again[0].episode_id, true, 100, Outcome::Success, "", "", {}}, t0 + 20s);
  s.channel_status(0, "w", true, again[0].episode_id, 1.0, "", t0 + 20s);
  const auto third = s.assign(t0 + 20s);
  ASSERT_EQ(third.size(), 1u);
  s.channel_status(0, "w", true, third[0].episode_id, 0, "physics failed at step 3", t0 + 21s);
  EXPECT_TRUE(s.assign(t0 + 50s).empty());
  EXPECT_EQ(s.assign(t0 + 51s).size(), 1u);
}

TEST(Scheduler, ARejectedRequestIsFlaggedAndRecordedElsewhereEpisodesAreSkipped) {
  auto s = make(3);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0, [](const EpisodeKey& k) { return k.seed == 1; });
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].key.seed, 2u) << "seed 1 was recorded by another process";
  s.result({d[0].episode_id, false, 0, Outcome::Rejected, "unknown arm 'x'", "", {}}, t0);
  s.channel_status(0, "w", true, d[0].episode_id, 0, "", t0);
  const auto recs = s.take_finished(t0);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_TRUE(recs[0].infrastructure);
  EXPECT_FALSE(recs[0].capabilities_missing) << "a rejected request ran nothing, without anything or not";
}

TEST(Scheduler, TwoWorkersAnnouncingOneChannelIdAreAConflict) {
  auto s = make(1);
  const auto t0 = Clock::now();
  s.channel_status(0, "host_a", true, "", 0, "", t0);
  EXPECT_TRUE(s.conflict().empty());
  s.channel_status(0, "host_b", true, "", 0, "", t0);
  EXPECT_NE(s.conflict().find("channel 0 is announced by two workers, 'host_a' and 'host_b'"), std::string::npos);
}

TEST(Scheduler, AMissingPhysicsReportLeavesPhysicsUnknownAfterTheWait) {
  auto s = make(1);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  s.result({d[0].episode_id, true, 50, Outcome::Success, "", "", {}}, t0);
  s.result({"someone-elses-episode", true, 50, Outcome::Success, "", "", {}}, t0);
  EXPECT_TRUE(s.take_finished(t0 + 1s).empty());
  const auto recs = s.take_finished(t0 + 2s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_EQ(recs[0].physics_s, 0.0);
  EXPECT_TRUE(s.done());
}

TEST(Scheduler, ALostWorkerLosesWhatItsChannelsRanAtOnceAndTheyServeAgainOnlyAfterAnnouncingThemselves) {
  auto s = make(4);
  const auto t0 = Clock::now();
  s.channel_status(0, "sim1", true, "", 0, "", t0);
  s.channel_status(11, "sim2", true, "", 0, "", t0);
  s.channel_status(12, "sim2", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 3u);
  s.worker_lost("sim2", t0 + 1s);
  EXPECT_EQ(s.running(), 1u) << "sim1's episode runs on";
  const auto recs = s.take_finished(t0 + 1s);
  ASSERT_EQ(recs.size(), 2u);
  for (const auto& r : recs) {
    EXPECT_TRUE(r.infrastructure);
    EXPECT_EQ(r.worker, "sim2");
    EXPECT_NE(r.reason.find("worker sim2 lost on channel 1"), std::string::npos) << r.reason;
  }
  EXPECT_TRUE(s.assign(t0 + 1s).empty()) << "sim2's channels are not used while it is gone";
  s.channel_status(11, "sim2", true, "", 0, "", t0 + 5s);
  const auto again = s.assign(t0 + 5s);
  ASSERT_EQ(again.size(), 1u) << "a channel that announces itself again serves again";
  EXPECT_EQ(again[0].channel, 11u);
}

// A worker starved of CPU loses liveliness and comes back without announcing anything new: its channel
// that was idle serves again at once; the one that ran a lost episode waits until it says it is idle.
TEST(Scheduler, AWorkerThatComesBackServesFromWhatItsChannelsLastAnnounced) {
  auto s = make(4);
  const auto t0 = Clock::now();
  s.channel_status(11, "sim2", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 1u);
  s.channel_status(11, "sim2", false, "", 0, "", t0);
  s.channel_status(12, "sim2", true, "", 0, "", t0);
  s.worker_lost("sim2", t0 + 1s);
  EXPECT_TRUE(s.assign(t0 + 1s).empty()) << "gone";
  s.worker_back("sim2");
  auto again = s.assign(t0 + 2s);
  ASSERT_EQ(again.size(), 1u) << "channel 12 last said it was idle";
  EXPECT_EQ(again[0].channel, 12u);
  EXPECT_TRUE(s.assign(t0 + 2s).empty()) << "channel 11 last said it was running (the lost episode)";
  s.channel_status(11, "sim2", true, d[0].episode_id, 0.1, "", t0 + 3s);
  again = s.assign(t0 + 3s);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].channel, 11u);
  s.worker_back("sim2");
  EXPECT_TRUE(s.assign(t0 + 3s).empty()) << "coming back twice frees nothing that is running";
}

TEST(Scheduler, UnderTheRerunRuleALostAttemptIsKeptAndTheEpisodeRunsAgainFirst) {
  auto s = make(3, 1);
  const auto t0 = Clock::now();
  s.channel_status(0, "sim1", true, "", 0, "", t0);
  s.channel_status(11, "sim2", true, "", 0, "", t0);
  const auto d = s.assign(t0);
  ASSERT_EQ(d.size(), 2u);
  ASSERT_EQ(d[1].channel, 11u);
  s.worker_lost("sim2", t0 + 1s);
  EXPECT_TRUE(s.take_finished(t0 + 1s).empty()) << "a lost attempt under the rule is no record";
  const auto losses = s.take_losses();
  ASSERT_EQ(losses.size(), 1u);
  EXPECT_EQ(losses[0].seed, 2u);
  EXPECT_EQ(losses[0].episode_id, d[1].episode_id);
  EXPECT_TRUE(losses[0].infrastructure);
  EXPECT_TRUE(s.take_losses().empty());
  EXPECT_EQ(s.pending(), 2u);

  // sim1 finishes; the lost seed 2 goes before seed 3, with a new episode id.
  s.result({d[0].episode_id, true, 100, Outcome::Success, "", "", {}}, t0 + 2s);
  s.channel_status(0, "sim1", true, d[0].episode_id, 0.2, "", t0 + 2s);
  const auto next = s.assign(t0 + 2s);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].key.seed, 2u);
  EXPECT_NE(next[0].episode_id, d[1].episode_id);

  // Lost again (no result in time): the rule allows one rerun, so this attempt is the episode's record.
  s.expire(t0 + 60s);
  EXPECT_TRUE(s.take_losses().empty());
  const auto recs = s.take_finished(t0 + 60s);
  ASSERT_EQ(recs.size(), 2u);
  EXPECT_EQ(recs[1].seed, 2u);
  EXPECT_TRUE(recs[1].infrastructure);
  // A late result of the first attempt changes nothing.
  s.result({d[1].episode_id, true, 100, Outcome::Success, "", "", {}}, t0 + 61s);
  EXPECT_TRUE(s.take_finished(t0 + 70s).empty());
}

TEST(Scheduler, UnderTheRerunRuleAnInfrastructureResultRunsAgainButAnAgentFailureDoesNot) {
  auto s = make(2, 1);
  const auto t0 = Clock::now();
  s.channel_status(0, "w", true, "", 0, "", t0);
  auto d = s.assign(t0);
  s.result({d[0].episode_id, false, 0, Outcome::Rejected, "governor busy", "", {}}, t0);
  EXPECT_EQ(s.take_losses().size(), 1u);
  s.channel_status(0, "w", true, d[0].episode_id, 0, "", t0);
  d = s.assign(t0);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].key.seed, 1u);
  s.result({d[0].episode_id, false, 300, Outcome::BudgetExhausted, "", "", {}}, t0 + 1s);
  EXPECT_TRUE(s.take_losses().empty()) << "a failure of the agent is a result, not a loss";
  s.channel_status(0, "w", true, d[0].episode_id, 0.5, "", t0 + 1s);
  const auto recs = s.take_finished(t0 + 1s);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_FALSE(recs[0].infrastructure);
}

}  // namespace
}  // namespace dh::campaign
