// Snapshots on new states: each snapshot's development and fresh rates with their cluster intervals, the
// first-to-last gains, Spearman ρ of the two columns (and why it is undefined when it is), infrastructure
// losses counted as failures, and a snapshot with no episodes refused by name.
#include <gtest/gtest.h>

#include "dh/evo/transfer.hpp"

using namespace dh;
using namespace dh::evo;

namespace {

/// `k` successes of `n` episodes spread over tasks 0..3 of cell goal-task.
std::vector<EpisodeRecord> episodes(unsigned k, unsigned n) {
  std::vector<EpisodeRecord> out;
  for (unsigned i = 0; i < n; ++i) {
    EpisodeRecord r;
    r.arm = "full";
    r.cell = "goal-task";
    r.task = i % 4;
    r.seed = 21 + i / 4;
    r.success = i < k;
    out.push_back(r);
  }
  return out;
}

SnapshotEpisodes snapshot(const std::string& name, unsigned dev_k, unsigned fresh_k, unsigned n = 40) {
  return {name, "lib-" + name, episodes(dev_k, n), episodes(fresh_k, n)};
}

}  // namespace

TEST(Transfer, RatesGainsAndTheRankCorrelationOfTheTwoColumns) {
  const auto s = summarise_transfer(
      {snapshot("a", 20, 18), snapshot("b", 24, 22), snapshot("c", 28, 21), snapshot("d", 32, 27)}, 2000);
  ASSERT_EQ(s.snapshots.size(), 4u);
  EXPECT_EQ(s.snapshots[0].dev_successes, 20u);
  EXPECT_EQ(s.snapshots[0].fresh_episodes, 40u);
  EXPECT_DOUBLE_EQ(s.snapshots[1].fresh.interval.point, 22.0 / 40);
  EXPECT_EQ(s.snapshots[1].dev.clusters, 4u);
  EXPECT_LE(s.snapshots[1].dev.interval.lo, 0.6);
  EXPECT_GE(s.snapshots[1].dev.interval.hi, 0.6);
  EXPECT_DOUBLE_EQ(s.dev_gain_pp, 30.0);
  EXPECT_DOUBLE_EQ(s.fresh_gain_pp, 22.5);
  // Ranks: development 1 2 3 4, fresh 1 3 2 4: ρ = 1 − 6·(0+1+1+0)/(4·15) = 0.8.
  ASSERT_TRUE(s.rho);
  EXPECT_NEAR(*s.rho, 0.8, 1e-12);
  const std::string md = transfer_markdown(s);
  EXPECT_NE(md.find("| 4 | d | lib-d | 32/40 = 80.0 %"), std::string::npos) << md;
  EXPECT_NE(md.find("development +30.0 points, fresh block +22.5 points"), std::string::npos) << md;
  EXPECT_NE(md.find("ρ of the two columns over 4 snapshots: 0.80"), std::string::npos) << md;
  // d against a on the fresh block: the first 18 episodes succeed in both, the next 9 in d alone.
  ASSERT_TRUE(s.fresh_paired);
  EXPECT_EQ(s.fresh_paired->n, 40u);
  EXPECT_EQ(s.fresh_paired->wins_a, 9u);
  EXPECT_EQ(s.fresh_paired->wins_b, 0u);
  EXPECT_DOUBLE_EQ(s.fresh_paired->diff, 9.0 / 40);
  EXPECT_NEAR(s.fresh_paired->p, 2.0 / 512, 1e-12);
  EXPECT_EQ(s.fresh_paired->clusters, 4u);
  EXPECT_NE(md.find("9 won, 0 lost, 31 alike of 40 pairs; +22.5 points"), std::string::npos) << md;
}

TEST(Transfer, TheLastSnapshotIsPairedWithTheFirstByCellTaskAndSeed) {
  auto first = snapshot("a", 10, 10), last = snapshot("b", 10, 10);
  last.fresh[0].success = false;            // a loss on seed 21's task 0
  last.fresh[12].success = true;            // a win on seed 24's task 0
  last.fresh.pop_back();                    // seed 30's task 3 only in the first: not a pair
  std::swap(last.fresh[1], last.fresh[2]);  // order does not matter
  const auto s = summarise_transfer({first, last}, 0);
  ASSERT_TRUE(s.fresh_paired);
  EXPECT_EQ(s.fresh_paired->n, 39u);
  EXPECT_EQ(s.fresh_paired->wins_a, 1u);
  EXPECT_EQ(s.fresh_paired->wins_b, 1u);
  EXPECT_DOUBLE_EQ(s.fresh_paired->p, 1.0);
  EXPECT_FALSE(summarise_transfer({snapshot("only", 10, 12)}, 0).fresh_paired);
}

TEST(Transfer, AnUndefinedRhoSaysWhyAndLossesCountAsFailures) {
  auto a = snapshot("a", 10, 10), b = snapshot("b", 12, 10);
  b.fresh[0].success = false;  // one of b's fresh successes was lost to infrastructure
  b.fresh[0].infrastructure = true;
  const auto s = summarise_transfer({a, b}, 0);
  EXPECT_EQ(s.snapshots[1].fresh_successes, 9u);
  ASSERT_TRUE(s.rho) << s.rho_note;
  const auto flat = summarise_transfer({snapshot("a", 10, 10), snapshot("b", 12, 10)}, 0);
  EXPECT_FALSE(flat.rho);
  EXPECT_FALSE(flat.rho_note.empty());
  EXPECT_NE(transfer_markdown(flat).find("Spearman ρ is undefined: "), std::string::npos);
  EXPECT_FALSE(summarise_transfer({snapshot("only", 10, 12)}, 0).rho) << "one snapshot has no ranking";
}

TEST(Transfer, ASnapshotWithoutEpisodesIsNamed) {
  auto empty = snapshot("b", 0, 0);
  empty.fresh.clear();
  try {
    summarise_transfer({snapshot("a", 10, 10), empty}, 0);
    FAIL() << "summarised a snapshot with no fresh episodes";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("snapshot b (lib-b) has no fresh episodes"), std::string::npos)
        << e.what();
  }
}
