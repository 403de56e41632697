#include "dh/common/stats.hpp"

#include <boost/math/distributions/binomial.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

namespace dh::stats {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Uniform index in [0, count): accepting only draws at or above 2^64 mod count leaves a range that is a
// whole multiple of count, so the modulo is unbiased.
std::uint64_t draw_index(std::mt19937_64& rng, std::uint64_t count) {
  const std::uint64_t reject_below = (0 - count) % count;
  for (;;) {
    const std::uint64_t u = rng();
    if (u >= reject_below) return u % count;
  }
}

struct Cluster {
  unsigned n = 0;
  int sum_d = 0;  // Σ (a_i − b_i) for pairs; Σ success_i for a rate
};

Interval cluster_bootstrap(const std::vector<Cluster>& clusters, double point, unsigned resamples,
                           std::uint64_t seed) {
  if (resamples == 0) return {kNaN, kNaN, point};
  std::mt19937_64 rng(seed);
  std::vector<double> diffs(resamples);
  for (double& d : diffs) {
    long n = 0, sum = 0;
    for (std::size_t i = 0; i < clusters.size(); ++i) {
      const Cluster& c = clusters[draw_index(rng, clusters.size())];
      n += c.n;
      sum += c.sum_d;
    }
    d = static_cast<double>(sum) / static_cast<double>(n);
  }
  return {percentile(diffs, 0.025), percentile(diffs, 0.975), point};
}

}  // namespace

Interval wilson(unsigned k, unsigned n, double z) {
  if (k > n)
    throw std::invalid_argument("wilson: successes k = " + std::to_string(k) +
                                " exceed trials n = " + std::to_string(n));
  if (!(z > 0) || !std::isfinite(z)) throw std::invalid_argument("wilson: z must be positive and finite");
  if (n == 0) return {0, 1, kNaN};
  const double nn = n, p = k / nn, z2 = z * z;
  const double denom = 1 + z2 / nn;
  const double centre = (p + z2 / (2 * nn)) / denom;
  const double half = z / denom * std::sqrt(p * (1 - p) / nn + z2 / (4 * nn * nn));
  // At k = 0 and k = n the bound is exactly 0 or 1; the formula only gets within rounding of it.
  return {k == 0 ? 0.0 : std::max(0.0, centre - half), k == n ? 1.0 : std::min(1.0, centre + half), p};
}

double sign_test_p(unsigned wins, unsigned losses) {
  const unsigned n = wins + losses;
  if (n == 0) return 1;
  const boost::math::binomial_distribution<double> dist(n, 0.5);
  return std::min(1.0, 2 * boost::math::cdf(dist, std::min(wins, losses)));
}

PairedSummary paired(const std::vector<PairedOutcome>& outcomes, unsigned resamples, std::uint64_t seed) {
  PairedSummary s;
  s.resamples = resamples;
  s.seed = seed;
  std::map<std::string, Cluster> by_name;  // ordered by name: the draw does not depend on input order
  for (const PairedOutcome& o : outcomes) {
    ++s.n;
    Cluster& c = by_name[o.cluster];
    ++c.n;
    if (o.a && !o.b) {
      ++s.wins_a;
      ++c.sum_d;
    } else if (o.b && !o.a) {
      ++s.wins_b;
      --c.sum_d;
    } else {
      ++s.ties;
    }
  }
  s.clusters = by_name.size();
  s.p = sign_test_p(s.wins_a, s.wins_b);
  if (s.n == 0) {
    s.diff = kNaN;
    s.wald = s.bootstrap = {kNaN, kNaN, kNaN};
    return s;
  }
  const double n = s.n;
  s.diff = (static_cast<double>(s.wins_a) - static_cast<double>(s.wins_b)) / n;
  // Σ d_i² / n − diff², since d_i² = 1 exactly on the discordant pairs.
  const double var = std::max(0.0, (s.wins_a + s.wins_b) / n - s.diff * s.diff);
  const double half = kZ95 * std::sqrt(var / n);
  s.wald = {std::max(-1.0, s.diff - half), std::min(1.0, s.diff + half), s.diff};
  std::vector<Cluster> clusters;
  clusters.reserve(by_name.size());
  for (const auto& [name, c] : by_name) clusters.push_back(c);
  s.bootstrap = cluster_bootstrap(clusters, s.diff, resamples, seed);
  return s;
}

ClusteredRate clustered_rate(const std::vector<ClusteredOutcome>& outcomes, unsigned resamples, std::uint64_t seed) {
  std::map<std::string, Cluster> by_name;  // ordered by name: the draw does not depend on input order
  unsigned successes = 0;
  for (const ClusteredOutcome& o : outcomes) {
    Cluster& c = by_name[o.cluster];
    ++c.n;
    c.sum_d += o.success;
    successes += o.success;
  }
  ClusteredRate r;
  r.clusters = by_name.size();
  if (outcomes.empty()) {
    r.interval = {kNaN, kNaN, kNaN};
    return r;
  }
  std::vector<Cluster> clusters;
  clusters.reserve(by_name.size());
  for (const auto& [name, c] : by_name) clusters.push_back(c);
  r.interval = cluster_bootstrap(clusters, static_cast<double>(successes) / outcomes.size(), resamples, seed);
  return r;
}

namespace {

/// Ranks from 1, ties at the mean of the ranks they span.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    const double mean_rank = (static_cast<double>(i) + static_cast<double>(j)) / 2 + 1;
    for (std::size_t k = i; k <= j; ++k) r[order[k]] = mean_rank;
    i = j + 1;
  }
  return r;
}

}  // namespace

double spearman(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    throw std::invalid_argument("spearman: " + std::to_string(x.size()) + " x values but " + std::to_string(y.size()) +
                                " y values");
  if (x.size() < 2) throw std::invalid_argument("spearman: needs at least two pairs");
  const auto has_nan = [](const std::vector<double>& v) {
    return std::any_of(v.begin(), v.end(), [](double a) { return std::isnan(a); });
  };
  if (has_nan(x) || has_nan(y)) throw std::invalid_argument("spearman: values contain NaN");
  const std::vector<double> rx = ranks(x), ry = ranks(y);
  const double mean = (static_cast<double>(x.size()) + 1) / 2;  // of the ranks 1..n, ties included
  double sxy = 0, sxx = 0, syy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (rx[i] - mean) * (ry[i] - mean);
    sxx += (rx[i] - mean) * (rx[i] - mean);
    syy += (ry[i] - mean) * (ry[i] - mean);
  }
  if (sxx == 0 || syy == 0) throw std::invalid_argument("spearman: a sample whose values are all equal has no ranks");
  return sxy / std::sqrt(sxx * syy);
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) throw std::invalid_argument("percentile: no values");
  if (!(q >= 0 && q <= 1)) throw std::invalid_argument("percentile: q must lie in [0, 1]");
  if (std::any_of(v.begin(), v.end(), [](double x) { return std::isnan(x); }))
    throw std::invalid_argument("percentile: values contain NaN");
  std::sort(v.begin(), v.end());
  const double h = (v.size() - 1) * q;
  const std::size_t i = static_cast<std::size_t>(h);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (h - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

}  // namespace dh::stats
