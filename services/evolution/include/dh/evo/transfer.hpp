// Snapshots on new states (issue 16, "Snapshots and transfer"): frozen libraries from one climb, each
// with its success on the development seeds and on a fresh block nobody tuned on. The paper's claim is
// that the ranking holds (Spearman ρ of the two columns) and that the first-to-last gain carries over.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "dh/common/episode_record.hpp"
#include "dh/common/stats.hpp"

namespace dh::evo {

/// One snapshot's episodes: on the development seeds and on the fresh block, in the climb's order.
struct SnapshotEpisodes {
  std::string name;     ///< as the user named it (a folder)
  std::string version;  ///< its library version
  std::vector<EpisodeRecord> dev, fresh;
};

struct SnapshotRates {
  std::string name, version;
  unsigned dev_successes = 0, dev_episodes = 0, fresh_successes = 0, fresh_episodes = 0;
  stats::ClusteredRate dev, fresh;  ///< pooled rate with its cell × task cluster-bootstrap interval
};

struct TransferSummary {
  std::vector<SnapshotRates> snapshots;
  /// Spearman ρ of development against fresh success over the snapshots; nullopt (with `rho_note`) when
  /// it is undefined: fewer than two snapshots, or one column all equal.
  std::optional<double> rho;
  std::string rho_note;
  double dev_gain_pp = 0, fresh_gain_pp = 0;  ///< last snapshot's rate minus the first's, points
  /// The last snapshot (A) against the first (B) on the fresh block, paired by cell, task and seed: the
  /// exact sign test and the cell × task cluster bootstrap of the difference. None with one snapshot.
  std::optional<stats::PairedSummary> fresh_paired;
};

/// The pooled success of `rows` with its cell × task cluster-bootstrap interval (a loss to infrastructure
/// is a failure).
stats::ClusteredRate clustered_success(const std::vector<EpisodeRecord>& rows, unsigned resamples = 20000);

/// Rates, ρ and gains; episodes lost to infrastructure count as failures, as in every report. Throws
/// std::invalid_argument naming a snapshot without episodes in either column.
TransferSummary summarise_transfer(const std::vector<SnapshotEpisodes>& snapshots,
                                   unsigned resamples = 20000);

/// The table and the figures under it, Markdown.
std::string transfer_markdown(const TransferSummary& s);

}  // namespace dh::evo
