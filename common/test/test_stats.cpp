#include <gtest/gtest.h>

#include "dh/common/stats.hpp"

#include <cmath>
#include <stdexcept>

using namespace dh::stats;

// Reference Wilson bounds: (p + z²/2n ± z·sqrt(p(1−p)/n + z²/4n²)) / (1 + z²/n) with z = 1.959963984540054,
// evaluated in python3 with mpmath at 30 digits. 81/263 is Newcombe's (1998) example: 0.2553–0.3662.
TEST(Wilson, MatchesReferenceValues) {
  struct Case {
    unsigned k, n;
    double lo, hi;
  };
  for (const Case& c : {Case{0, 10, 0.0, 0.2775327998628892}, Case{10, 10, 0.7224672001371108, 1.0},
                        Case{5, 10, 0.236593090512564, 0.763406909487436},
                        Case{81, 263, 0.25528851987827423, 0.36620957698280006},
                        Case{18, 20, 0.69896635477151273, 0.97213351878623178}}) {
    const Interval w = wilson(c.k, c.n);
    EXPECT_NEAR(w.lo, c.lo, 1e-12) << c.k << "/" << c.n;
    EXPECT_NEAR(w.hi, c.hi, 1e-12) << c.k << "/" << c.n;
    EXPECT_DOUBLE_EQ(w.point, double(c.k) / c.n);
  }
}

TEST(Wilson, BoundsAreExactAtTheEnds) {
  EXPECT_EQ(wilson(0, 7).lo, 0.0);
  EXPECT_EQ(wilson(7, 7).hi, 1.0);
  EXPECT_EQ(wilson(1, 1).hi, 1.0);
}

TEST(Wilson, NoTrialsIsTheWholeRangeWithoutAPoint) {
  const Interval w = wilson(0, 0);
  EXPECT_EQ(w.lo, 0.0);
  EXPECT_EQ(w.hi, 1.0);
  EXPECT_TRUE(std::isnan(w.point));
}

TEST(Wilson, RejectsBadInput) {
  EXPECT_THROW(wilson(11, 10), std::invalid_argument);
  EXPECT_THROW(wilson(1, 10, 0.0), std::invalid_argument);
  EXPECT_THROW(wilson(1, 10, NAN), std::invalid_argument);
}

// Exact values: 2·Σ_{i≤min} C(n,i) / 2^n with python3 fractions and math.comb.
TEST(SignTest, SmallCasesMatchExactSums) {
  EXPECT_NEAR(sign_test_p(3, 1), 5.0 / 8, 1e-15);
  EXPECT_NEAR(sign_test_p(5, 2), 29.0 / 64, 1e-15);
  EXPECT_NEAR(sign_test_p(2, 5), 29.0 / 64, 1e-15) << "two-sided: symmetric in W and L";
  EXPECT_NEAR(sign_test_p(6, 0), 1.0 / 32, 1e-15);
  EXPECT_NEAR(sign_test_p(7, 3), 11.0 / 32, 1e-15);
  EXPECT_EQ(sign_test_p(10, 10), 1.0);
  EXPECT_EQ(sign_test_p(0, 0), 1.0);
  EXPECT_EQ(sign_test_p(1, 0), 1.0);
}

// The paper's values, checked against the same exact sums (python3 fractions).
TEST(SignTest, PaperValuesIncludingTinyTails) {
  EXPECT_NEAR(sign_test_p(12, 4) / (2517.0 / 32768), 1, 1e-12);
  EXPECT_EQ(sign_test_p(11, 10), 1.0);
  EXPECT_NEAR(sign_test_p(9, 7) / (26333.0 / 32768), 1, 1e-12);
  EXPECT_NEAR(sign_test_p(20, 0) / (1.0 / 524288), 1, 1e-12);
  EXPECT_NEAR(sign_test_p(14, 3) / (417.0 / 32768), 1, 1e-12);
  EXPECT_NEAR(sign_test_p(89, 8) / 1.999575403524945e-18, 1, 1e-10);
  EXPECT_NEAR(sign_test_p(473, 7) / 7.248545663206941e-130, 1, 1e-10);
}

namespace {
std::vector<PairedOutcome> repeat(const std::string& cluster, bool a, bool b, int times) {
  return std::vector<PairedOutcome>(times, PairedOutcome{cluster, a, b});
}
void append(std::vector<PairedOutcome>& to, const std::vector<PairedOutcome>& more) {
  to.insert(to.end(), more.begin(), more.end());
}
}  // namespace

TEST(Paired, CountsWinsLossesTiesAndTheWaldInterval) {
  // 10 episodes: A alone wins 4, B alone wins 1, both succeed 3, both fail 2.
  std::vector<PairedOutcome> o;
  append(o, repeat("goal/1", true, false, 4));
  append(o, repeat("goal/1", false, true, 1));
  append(o, repeat("goal/2", true, true, 3));
  append(o, repeat("goal/2", false, false, 2));
  const PairedSummary s = paired(o, 2000, 7);
  EXPECT_EQ(s.n, 10u);
  EXPECT_EQ(s.wins_a, 4u);
  EXPECT_EQ(s.wins_b, 1u);
  EXPECT_EQ(s.ties, 5u);
  EXPECT_EQ(s.clusters, 2u);
  EXPECT_DOUBLE_EQ(s.diff, 0.3);
  EXPECT_NEAR(s.p, 3.0 / 8, 1e-15);  // 2·(1 + 5)/32
  // d: four 1, one −1, five 0 → mean 0.3, (1/n)Σd² − mean² = 0.5 − 0.09 = 0.41.
  const double half = kZ95 * std::sqrt(0.41 / 10);
  EXPECT_NEAR(s.wald.lo, 0.3 - half, 1e-12);
  EXPECT_NEAR(s.wald.hi, 0.3 + half, 1e-12);
  EXPECT_DOUBLE_EQ(s.wald.point, 0.3);
}

TEST(Paired, WaldIntervalIsClampedToPlusMinusOne) {
  const PairedSummary s = paired(repeat("c", true, false, 3), 100, 1);
  EXPECT_EQ(s.wald.hi, 1.0);
  EXPECT_EQ(s.wald.lo, 1.0) << "zero variance: the interval is the point";
}

TEST(Paired, BootstrapIsDeterministicForASeedAndHoldsThePoint) {
  std::vector<PairedOutcome> o;
  for (int t = 0; t < 8; ++t) {
    const std::string c = "goal/" + std::to_string(t);
    append(o, repeat(c, true, false, t % 3));
    append(o, repeat(c, false, true, t % 2));
    append(o, repeat(c, true, true, 2));
  }
  const PairedSummary s1 = paired(o, 5000, 42), s2 = paired(o, 5000, 42), s3 = paired(o, 5000, 43);
  EXPECT_EQ(s1.bootstrap.lo, s2.bootstrap.lo);
  EXPECT_EQ(s1.bootstrap.hi, s2.bootstrap.hi);
  EXPECT_LE(s1.bootstrap.lo, s1.diff);
  EXPECT_GE(s1.bootstrap.hi, s1.diff);
  EXPECT_LT(s1.bootstrap.lo, s1.bootstrap.hi);
  EXPECT_TRUE(s1.bootstrap.lo != s3.bootstrap.lo || s1.bootstrap.hi != s3.bootstrap.hi)
      << "another seed draws other samples";
  EXPECT_EQ(s1.resamples, 5000u);
  EXPECT_EQ(s1.seed, 42u);

  std::vector<PairedOutcome> reversed(o.rbegin(), o.rend());
  const PairedSummary r = paired(reversed, 5000, 42);
  EXPECT_EQ(r.bootstrap.lo, s1.bootstrap.lo) << "input order does not change the draw";
  EXPECT_EQ(r.bootstrap.hi, s1.bootstrap.hi);
}

TEST(Paired, IdenticalClustersGiveAZeroWidthBootstrapInterval) {
  std::vector<PairedOutcome> o;
  for (int t = 0; t < 5; ++t) {
    const std::string c = "long/" + std::to_string(t);
    append(o, repeat(c, true, false, 1));
    append(o, repeat(c, false, false, 1));
  }
  const PairedSummary s = paired(o, 1000, 3);
  EXPECT_DOUBLE_EQ(s.bootstrap.lo, 0.5);
  EXPECT_DOUBLE_EQ(s.bootstrap.hi, 0.5);
}

TEST(Paired, EmptyInputHasNoEstimate) {
  const PairedSummary s = paired({});
  EXPECT_EQ(s.n, 0u);
  EXPECT_EQ(s.p, 1.0);
  EXPECT_TRUE(std::isnan(s.diff));
  EXPECT_TRUE(std::isnan(s.wald.lo));
  EXPECT_TRUE(std::isnan(s.bootstrap.hi));
}

TEST(Paired, NoResamplesLeavesTheBootstrapOut) {
  const PairedSummary s = paired(repeat("c", true, false, 2), 0);
  EXPECT_TRUE(std::isnan(s.bootstrap.lo));
  EXPECT_DOUBLE_EQ(s.diff, 1.0);
}

namespace {
std::vector<ClusteredOutcome> cluster(const std::string& name, int successes, int failures) {
  std::vector<ClusteredOutcome> o(successes, ClusteredOutcome{name, true});
  o.insert(o.end(), failures, ClusteredOutcome{name, false});
  return o;
}
}  // namespace

TEST(ClusteredRate, WholeClustersThatSucceedOrFailTogetherWidenTheIntervalBeyondWilson) {
  // 10 layouts × 20 seeds, 9 layouts always succeed and one never: 180 of 200 episodes, but only 10
  // independent draws.
  std::vector<ClusteredOutcome> o;
  for (int t = 0; t < 10; ++t) {
    const auto c = cluster("goal/" + std::to_string(t), t == 3 ? 0 : 20, t == 3 ? 20 : 0);
    o.insert(o.end(), c.begin(), c.end());
  }
  const ClusteredRate r = clustered_rate(o, 20000, 7);
  const Interval w = wilson(180, 200);
  EXPECT_EQ(r.clusters, 10u);
  EXPECT_DOUBLE_EQ(r.interval.point, 0.9);
  EXPECT_LT(r.interval.lo, w.lo - 0.1) << r.interval.lo << " vs Wilson " << w.lo;
  EXPECT_DOUBLE_EQ(r.interval.hi, 1.0) << "a resample without the failing layout";
}

TEST(ClusteredRate, ClustersAlikeGiveAZeroWidthIntervalAndTheDrawIsDeterministic) {
  std::vector<ClusteredOutcome> o;
  for (int t = 0; t < 6; ++t) {
    const auto c = cluster("long/" + std::to_string(t), 3, 1);
    o.insert(o.end(), c.begin(), c.end());
  }
  const ClusteredRate r = clustered_rate(o, 1000, 3);
  EXPECT_DOUBLE_EQ(r.interval.lo, 0.75);
  EXPECT_DOUBLE_EQ(r.interval.hi, 0.75);

  std::vector<ClusteredOutcome> mixed = cluster("a", 5, 1);
  for (const auto& c : {cluster("b", 1, 5), cluster("c", 3, 3)}) mixed.insert(mixed.end(), c.begin(), c.end());
  const ClusteredRate m1 = clustered_rate(mixed, 3000, 11);
  const ClusteredRate m2 = clustered_rate({mixed.rbegin(), mixed.rend()}, 3000, 11);
  EXPECT_EQ(m1.interval.lo, m2.interval.lo) << "input order does not change the draw";
  EXPECT_EQ(m1.interval.hi, m2.interval.hi);
  EXPECT_LE(m1.interval.lo, m1.interval.point);
  EXPECT_GE(m1.interval.hi, m1.interval.point);
}

TEST(ClusteredRate, NoOutcomesOrNoResamplesHaveNoInterval) {
  const ClusteredRate none = clustered_rate({});
  EXPECT_EQ(none.clusters, 0u);
  EXPECT_TRUE(std::isnan(none.interval.point));
  EXPECT_TRUE(std::isnan(none.interval.lo));
  const ClusteredRate no_draws = clustered_rate(cluster("a", 1, 1), 0);
  EXPECT_DOUBLE_EQ(no_draws.interval.point, 0.5);
  EXPECT_TRUE(std::isnan(no_draws.interval.hi));
}

// Textbook values: the IQ / hours of television example (Wikipedia, "Spearman's rank correlation
// coefficient": ρ = −29/165), Σd² = 0 and a full reversal, and ties at their mean rank (by hand:
// ranks x 1, 2.5, 2.5, 4 and y 1, 3, 2, 4 give 4.5 / √(4.5 · 5)).
TEST(Spearman, TextbookValuesAndTies) {
  EXPECT_NEAR(spearman({106, 86, 100, 101, 99, 103, 97, 113, 112, 110}, {7, 0, 27, 50, 28, 29, 20, 12, 6, 17}),
              -29.0 / 165, 1e-12);
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {10, 20, 30, 40}), 1.0);
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  EXPECT_NEAR(spearman({1, 2, 2, 3}, {1, 3, 2, 4}), 4.5 / std::sqrt(4.5 * 5), 1e-12);
  EXPECT_DOUBLE_EQ(spearman({14.3, 20.1, 25.0, 28.6}, {14.4, 19.0, 24.2, 28.8}), 1.0) << "the paper's ρ = 1.00 shape";
}

TEST(Spearman, RejectsBadInput) {
  EXPECT_THROW(spearman({1, 2}, {1}), std::invalid_argument);
  EXPECT_THROW(spearman({1}, {1}), std::invalid_argument);
  EXPECT_THROW(spearman({1, 1, 1}, {1, 2, 3}), std::invalid_argument);
  EXPECT_THROW(spearman({1, NAN}, {1, 2}), std::invalid_argument);
}

TEST(Percentile, InterpolatesBetweenOrderStatistics) {
  const std::vector<double> v{5, 1, 4, 2, 3};  // sorted 1..5, h = 4q
  EXPECT_DOUBLE_EQ(percentile(v, 0), 1);
  EXPECT_DOUBLE_EQ(percentile(v, 0.5), 3);
  EXPECT_DOUBLE_EQ(percentile(v, 1), 5);
  EXPECT_DOUBLE_EQ(percentile(v, 0.9), 4.6);
  EXPECT_DOUBLE_EQ(percentile({10, 20}, 0.25), 12.5);
  EXPECT_DOUBLE_EQ(percentile({7}, 0.99), 7);
}

TEST(Percentile, RejectsBadInput) {
  EXPECT_THROW(percentile({}, 0.5), std::invalid_argument);
  EXPECT_THROW(percentile({1, 2}, 1.5), std::invalid_argument);
  EXPECT_THROW(percentile({1, 2}, -0.1), std::invalid_argument);
  EXPECT_THROW(percentile({1, NAN}, 0.5), std::invalid_argument);
}
