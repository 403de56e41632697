// The view's board: channel rows from announcements and the governor's live state, workers lost, campaign
// tallies with Wilson intervals, and campaigns forgotten after a while.
#include <gtest/gtest.h>

#include "dh/view/board.hpp"

using namespace dh::view;
using namespace std::chrono_literals;

TEST(Board, ChannelsJoinTheirAnnouncementAndTheGovernorsLiveState) {
  Board b;
  const auto t0 = Clock::time_point{} + 1h;
  b.on_channel({0, "local_a", false, ""}, t0);
  b.on_channel({1, "local_a", true, "goal/8/1#3"}, t0);
  EpisodeLive e;
  e.channel = 1;
  e.episode_id = "goal/8/1#3";
  e.arm = "full";
  e.cell = "goal";
  e.task = 8;
  e.seed = 1;
  e.step = 40;
  e.budget_steps = 300;
  e.capability = "pick_place";
  e.decision = "continue";
  e.reason = "command running";
  e.evidence = "/runs/evidence/goal_8_1_3.jsonl";
  b.on_live(e, t0 + 1s);
  auto s = b.snapshot(t0 + 2s);
  ASSERT_EQ(s["channels"].size(), 2u);
  EXPECT_EQ(s["channels"][0]["state"], "idle");
  EXPECT_EQ(s["channels"][0]["host"], "local_a");
  const auto& row = s["channels"][1];
  EXPECT_EQ(row["state"], "running");
  EXPECT_EQ(row["step"], 40);
  EXPECT_EQ(row["capability"], "pick_place");
  EXPECT_EQ(row["evidence"], e.evidence);
  EXPECT_DOUBLE_EQ(row["age_s"].get<double>(), 1.0);

  // The episode ends: the governor says so; then the worker goes idle; a late sample of the running
  // episode does not bring it back.
  e.ended = true;
  e.outcome = "success";
  e.step = 120;
  b.on_live(e, t0 + 3s);
  b.on_channel({1, "local_a", false, ""}, t0 + 3s);
  e.ended = false;
  e.step = 110;
  b.on_live(e, t0 + 4s);
  s = b.snapshot(t0 + 4s);
  EXPECT_EQ(s["channels"][1]["state"], "ended");
  EXPECT_EQ(s["channels"][1]["outcome"], "success");
  EXPECT_EQ(s["channels"][1]["step"], 120);

  // Its worker is lost: both its channels say so until they announce again.
  b.on_worker_lost("local_a", t0 + 5s);
  s = b.snapshot(t0 + 5s);
  EXPECT_EQ(s["channels"][0]["state"], "lost");
  EXPECT_EQ(s["channels"][1]["state"], "lost");
  b.on_channel({0, "local_a", false, ""}, t0 + 6s);
  EXPECT_EQ(b.snapshot(t0 + 6s)["channels"][0]["state"], "idle");
  // The worker comes back without announcing: channel 1 shows what it last said.
  b.on_worker_back("local_a", t0 + 7s);
  EXPECT_EQ(b.snapshot(t0 + 7s)["channels"][1]["state"], "ended");
}

TEST(Board, CampaignsCarryTheirTalliesAndAreForgottenWhenSilent) {
  Board b(10min);
  const auto t0 = Clock::time_point{} + 1h;
  CampaignProgress p{"runs/c.db", 80, 20, 15, 1, 2, 1.5, 40.0, false, {{"full", "goal", 9, 10}, {"static", "goal", 0, 0}}};
  b.on_progress(p, t0);
  p.done = 21;
  b.on_progress(p, t0 + 1s);
  b.on_progress({"runs/d.db", 10, 0, 0, 0, 0, -1, -1, false, {}}, t0 + 1s);
  auto s = b.snapshot(t0 + 2s);
  ASSERT_EQ(s["campaigns"].size(), 2u);
  const auto& c = s["campaigns"][0];
  EXPECT_EQ(c["campaign"], "runs/c.db");
  EXPECT_EQ(c["done"], 21);
  EXPECT_EQ(c["reran"], 2);
  EXPECT_DOUBLE_EQ(c["eta_s"].get<double>(), 40.0);
  EXPECT_DOUBLE_EQ(c["cells"][0]["rate"].get<double>(), 0.9);
  EXPECT_LT(c["cells"][0]["wilson_lo"].get<double>(), 0.9);
  EXPECT_GT(c["cells"][0]["wilson_hi"].get<double>(), 0.9);
  EXPECT_TRUE(c["cells"][1]["rate"].is_null()) << "no episode yet";
  EXPECT_TRUE(s["campaigns"][1]["rate_per_s"].is_null());
  EXPECT_TRUE(s["campaigns"][1]["eta_s"].is_null());
  EXPECT_EQ(b.snapshot(t0 + 1s + 10min + 1s)["campaigns"].size(), 0u);
}
