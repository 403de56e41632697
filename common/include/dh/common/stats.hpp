// Statistics a campaign report needs (DESIGN.md §9): Wilson and cluster-bootstrap intervals for success
// rates, the exact sign test and two intervals for paired arm comparisons, and percentiles. Pure functions; bad input throws
// std::invalid_argument naming the argument.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dh::stats {

/// z of a two-sided 95 % normal interval (the 0.975 quantile of N(0,1)).
inline constexpr double kZ95 = 1.959963984540054;

/// An estimate and its interval.
struct Interval {
  double lo = 0, hi = 0, point = 0;
};

/// Wilson score interval (no continuity correction) for k successes in n trials, point k/n. n = 0 carries
/// no information: [0, 1] with point NaN. Throws when k > n or z is not positive and finite.
Interval wilson(unsigned k, unsigned n, double z = kZ95);

/// Exact two-sided binomial sign test over discordant pairs: min(1, 2·P(X ≤ min(W, L))), X ~ Bin(W + L, 1/2).
/// W + L = 0 gives 1. Accurate in relative terms down to the smallest normal double (≈1e-308), 0 below.
double sign_test_p(unsigned wins, unsigned losses);

/// One pair of episodes run by arms A and B on the same key. `cluster` groups episodes the bootstrap
/// resamples together (a campaign uses "cell/task").
struct PairedOutcome {
  std::string cluster;
  bool a = false, b = false;
};

struct PairedSummary {
  unsigned n = 0;
  unsigned wins_a = 0;  ///< A succeeded, B failed
  unsigned wins_b = 0;  ///< B succeeded, A failed
  unsigned ties = 0;
  double diff = 0;  ///< (successes of A − successes of B) / n; NaN when n = 0
  double p = 1;     ///< sign_test_p(wins_a, wins_b)
  /// Both intervals carry diff as their point.
  /// Wald: diff ± z·sqrt(s²/n), s² = (1/n)·Σ(d_i − diff)² over d_i = a_i − b_i ∈ {−1, 0, 1} (the textbook
  /// Wald interval for a difference of paired proportions); clamped to [−1, 1]. NaN when n = 0.
  Interval wald;
  /// 2.5th/97.5th percentiles of the pooled difference over `resamples` cluster-bootstrap samples (as
  /// many clusters drawn with replacement as there are). NaN when n = 0 or resamples = 0.
  Interval bootstrap;
  unsigned clusters = 0;
  unsigned resamples = 0;
  std::uint64_t seed = 0;
};

/// Summarises paired outcomes. The bootstrap is deterministic for a seed: std::mt19937_64 with an
/// unbiased index draw of our own, so the interval is the same on every standard library.
PairedSummary paired(const std::vector<PairedOutcome>& outcomes, unsigned resamples = 20000,
                     std::uint64_t seed = 20260926);

/// One episode's success and the cluster it belongs to. A campaign clusters by "cell/task": a task's seeds
/// only jitter one layout, so its episodes are not independent draws.
struct ClusteredOutcome {
  std::string cluster;
  bool success = false;
};

struct ClusteredRate {
  /// point: the pooled rate; lo/hi: 2.5th/97.5th percentiles of the pooled rate over `resamples`
  /// cluster-bootstrap samples (as many clusters drawn with replacement as there are). NaN when there are
  /// no outcomes; lo/hi NaN when resamples = 0.
  Interval interval;
  unsigned clusters = 0;
};

/// A success rate with the interval that respects clustering, to stand beside Wilson's (which treats every
/// episode as independent). Deterministic for a seed, like paired().
ClusteredRate clustered_rate(const std::vector<ClusteredOutcome>& outcomes, unsigned resamples = 20000,
                             std::uint64_t seed = 20260926);

/// Spearman's rank correlation ρ of paired samples: Pearson's correlation of their ranks, tied values
/// taking the mean of the ranks they span. Throws std::invalid_argument for samples of different lengths,
/// fewer than two pairs, a NaN, or a sample whose values are all equal (ρ undefined).
double spearman(const std::vector<double>& x, const std::vector<double>& y);

/// The q-quantile (q in [0, 1]) by linear interpolation between order statistics: with v sorted and
/// h = (n − 1)·q, v[⌊h⌋] + (h − ⌊h⌋)·(v[⌊h⌋ + 1] − v[⌊h⌋]) (Hyndman & Fan type 7, R's and numpy's
/// default). Throws on an empty v, a NaN in v or q outside [0, 1].
double percentile(std::vector<double> v, double q);

}  // namespace dh::stats
