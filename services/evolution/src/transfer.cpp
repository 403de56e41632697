#include "dh/evo/transfer.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <map>
#include <stdexcept>

namespace dh::evo {
namespace {

unsigned successes(const std::vector<EpisodeRecord>& rows) {
  return static_cast<unsigned>(std::count_if(rows.begin(), rows.end(), [](const auto& r) { return r.success; }));
}

std::string rate(unsigned k, unsigned n, const stats::ClusteredRate& c) {
  return fmt::format("{}/{} = {:.1f} % [{:.1f}, {:.1f}]", k, n, 100 * c.interval.point, 100 * c.interval.lo,
                     100 * c.interval.hi);
}

/// The episodes of `a` and `b` on the same cell, task and seed, clustered by cell × task.
stats::PairedSummary paired_by_seed(const std::vector<EpisodeRecord>& a, const std::vector<EpisodeRecord>& b,
                                    unsigned resamples) {
  std::map<std::string, bool> b_success;
  for (const auto& r : b) b_success[r.cluster() + "/" + std::to_string(r.seed)] = r.success;
  std::vector<stats::PairedOutcome> pairs;
  for (const auto& r : a) {
    const auto other = b_success.find(r.cluster() + "/" + std::to_string(r.seed));
    if (other != b_success.end()) pairs.push_back({r.cluster(), r.success, other->second});
  }
  return stats::paired(pairs, resamples);
}

}  // namespace

stats::ClusteredRate clustered_success(const std::vector<EpisodeRecord>& rows, unsigned resamples) {
  std::vector<stats::ClusteredOutcome> outcomes;
  for (const auto& r : rows) outcomes.push_back({r.cluster(), r.success});
  return stats::clustered_rate(outcomes, resamples);
}

TransferSummary summarise_transfer(const std::vector<SnapshotEpisodes>& snapshots, unsigned resamples) {
  TransferSummary s;
  std::vector<double> dev, fresh;
  for (const auto& snap : snapshots) {
    if (snap.dev.empty() || snap.fresh.empty())
      throw std::invalid_argument("snapshot " + snap.name + " (" + snap.version + ") has no " +
                                  (snap.dev.empty() ? "development" : "fresh") + " episodes");
    SnapshotRates r;
    r.name = snap.name;
    r.version = snap.version;
    r.dev = clustered_success(snap.dev, resamples);
    r.fresh = clustered_success(snap.fresh, resamples);
    r.dev_successes = successes(snap.dev);
    r.fresh_successes = successes(snap.fresh);
    r.dev_episodes = static_cast<unsigned>(snap.dev.size());
    r.fresh_episodes = static_cast<unsigned>(snap.fresh.size());
    dev.push_back(r.dev.interval.point);
    fresh.push_back(r.fresh.interval.point);
    s.snapshots.push_back(std::move(r));
  }
  if (s.snapshots.empty()) throw std::invalid_argument("no snapshots to compare");
  s.dev_gain_pp = 100 * (dev.back() - dev.front());
  s.fresh_gain_pp = 100 * (fresh.back() - fresh.front());
  if (snapshots.size() > 1)
    s.fresh_paired = paired_by_seed(snapshots.back().fresh, snapshots.front().fresh, resamples);
  try {
    s.rho = stats::spearman(dev, fresh);
  } catch (const std::invalid_argument& e) {
    s.rho_note = e.what();
  }
  return s;
}

std::string transfer_markdown(const TransferSummary& s) {
  std::string md = "| # | snapshot | library | development | fresh block |\n|---|---|---|---|---|\n";
  for (std::size_t i = 0; i < s.snapshots.size(); ++i) {
    const SnapshotRates& r = s.snapshots[i];
    md += fmt::format("| {} | {} | {} | {} | {} |\n", i + 1, r.name, r.version,
                      rate(r.dev_successes, r.dev_episodes, r.dev),
                      rate(r.fresh_successes, r.fresh_episodes, r.fresh));
  }
  md += "\nIntervals: cell × task cluster bootstrap, 95 %.\n\n";
  md += fmt::format("First to last snapshot: development {:+.1f} points, fresh block {:+.1f} points.\n",
                    s.dev_gain_pp, s.fresh_gain_pp);
  md += s.rho ? fmt::format("Spearman ρ of the two columns over {} snapshots: {:.2f}.\n", s.snapshots.size(),
                            *s.rho)
              : "Spearman ρ is undefined: " + s.rho_note + ".\n";
  if (const auto& p = s.fresh_paired)
    md += fmt::format(
        "Last against first on the fresh block, paired by cell, task and seed: {} won, {} lost, {} alike of "
        "{} pairs; {:+.1f} points, cell × task cluster bootstrap [{:+.1f}, {:+.1f}] ({} clusters); exact "
        "sign test p = {:.2g}.\n",
        p->wins_a, p->wins_b, p->ties, p->n, 100 * p->diff, 100 * p->bootstrap.lo, 100 * p->bootstrap.hi,
        p->clusters, p->p);
  return md;
}

}  // namespace dh::evo
