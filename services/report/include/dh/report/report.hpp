// The campaign report (DESIGN.md §9): success with Wilson 95 % intervals per arm and cell, paired
// comparisons of every two arms (exact sign test, paired Wald and cell-bootstrap intervals), per-task
// tables, episode wall clock, decision and planner latencies from the evidence files, and plots.
//
// Rules: an episode lost to infrastructure is a failure in every denominator and is counted, never
// dropped. A missing or unreadable evidence file is counted (evidence.missing), never fatal; torn lines
// inside one are skipped by dh::read_evidence. A missing gnuplot skips the plots, never the report.
#pragma once

#include "dh/common/episode_record.hpp"
#include "dh/common/suite.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace dh::report {

inline constexpr const char* kBenchmarkNote =
    "This is DynaHarness's own MuJoCo workcell benchmark, modelled on LIBERO-Goal / LIBERO-10 and "
    "LIBERO-Pro perturbations. It is NOT LIBERO or LIBERO-Pro, and its results are not comparable with "
    "published LIBERO numbers.";

/// A failed episode's attribution layer, as `dh attribute` stored it in the campaign database.
struct Attributed {
  std::string arm, cell;
  unsigned task = 0, seed = 0;
  int layer = -1;  ///< upstream = 0
  std::string name;
  bool harness = false;
};

/// The rows of one campaign database; `label` names it in the report (e.g. its file name). Rows of all
/// sources are pooled: an (arm, cell, task, seed) key seen twice in one arm is counted as a duplicate;
/// only its first row (in source, then row order) counts anywhere else (rates, pairs, tasks, times,
/// failures by layer).
struct Source {
  std::string label;
  std::vector<EpisodeRecord> rows;
  std::vector<Attributed> attributed{};  ///< under ReportOptions::attribution_config; empty: none stored
};

struct ReportOptions {
  std::filesystem::path out_dir;  ///< render() only; created when missing
  std::string title = "DynaHarness campaign report";
  unsigned bootstrap_resamples = 20000;
  std::uint64_t bootstrap_seed = 20260926;
  /// The attribution file's content hash the sources' labels were read under ("" : no attribution).
  std::string attribution_config;
  bool plots = true;
  /// A `dh train-policy` output folder (train.json, loss.csv): the report then describes the embedded
  /// policy and its loss curve. Empty: no policy section.
  std::filesystem::path policy_dir;
  /// The "-pos" cells' position perturbations, by cell (load_suites): their episodes are also tallied by
  /// the magnitude their seed picked, for success against displacement. Empty: no such table.
  std::map<std::string, PosSpec> positions;
  /// Filmstrips of chosen episodes (dh film), already written under out_dir: shown with their captions.
  struct Film {
    std::string file;  ///< relative to out_dir; empty when it could not be made
    std::string caption, note;  ///< note: why it could not be made, or what the strip does not show
  };
  std::vector<Film> films;
};

struct ReportFiles {
  std::filesystem::path markdown, html, json;
  std::vector<std::filesystem::path> plots;  ///< PNGs written; empty when plots were skipped
  bool plots_skipped = false;
  std::string plots_note;  ///< why they were skipped
};

/// The report as one JSON object (what `dh report --json` prints). Arms and cells keep the order in which
/// they first appear; pairs of arms (a, b) follow that order with a first. Keys:
///   title, benchmark_note, sources [{label, rows}], rows, arms, cells, infrastructure, duplicates,
///   summary    [{arm, cell, successes, episodes, rate, wilson_lo, wilson_hi, cluster_lo, cluster_hi, clusters,
///               infrastructure, tick_limit}]; cluster_*: the cell/task cluster bootstrap (bootstrap's
///               resamples and seed) beside Wilson's, which treats episodes as independent
///   arm_totals [{arm, the same fields without cell}]
///   paired     [{a, b, overall: P, cells: [{cell, P...}]}], P = {n, wins, losses, ties, diff_pp,
///               wald_lo_pp, wald_hi_pp, bootstrap_lo_pp, bootstrap_hi_pp, clusters, p}; wins = a
///               succeeded and b failed; bootstrap clusters are cell/task
///   bootstrap  {resamples, seed}
///   attribution {config, cells: [{arm, cell, failed, attributed, layers: [{layer, name, harness, count}],
///               u_d}]}: failures by layer per arm and cell (u_d: those the harness owns); config null and
///               cells empty when no source holds labels
///   tasks      [{arm, cell, task, successes, episodes}]
///   positions  [{arm, cell, magnitude, radius_m, successes, episodes, rate, wilson_*, cluster_*, ...}]: "-pos"
///               cells by the magnitude each seed picked (ReportOptions::positions)
///   wall_clock [{arm, cell, episodes, mean_s, p50_s, p90_s, total_s}]
///   latency    {decision: L, planner: L, unanswered_plan_requests, by_arm: [{arm, decision, planner}]},
///               L = {count, p50_ms, p90_ms, p99_ms}
///   mechanisms [{arm, episodes, decisions: {kind: count}, refusals, commands: [{capability, dispatched,
///               completed, steps}], steps, policy_step_share}] from the evidence files (a command's
///               steps run from its dispatch to the next dispatch or the episode's end; the share is
///               vla_act's steps over all, null without steps); decision kinds are the fast brain's (substitute,
///               insert_recovery, resume, retry, hand_to_vla, request_replan after a failure, next_step
///               after a completion, next_in_sequence, stop_success, give_up)
///   execution  [{arm, outcomes: {outcome: episodes}, budget_used: {success: Q, failure: Q} (steps / budget
///               at the end; losses to infrastructure left out), steps_after_progress: Q (failures: from the
///               last step a command's progress rose or one completed, to the end), traced (episodes whose
///               evidence holds their end), zero_policy_steps (of those, episodes never under vla_act),
///               time_to_success: {steps: Q (the simulator's first goal step)}, wall_s: {success: Q,
///               failure: Q} (losses to infrastructure left out), budget_used_values: {success: [..], failure: [..]}}], Q = {count, p10, p50, p90,
///               mean}: the paper's execution figures
///   films      [{file, caption, note}] (options.films)
///   evidence   {read, missing, not_recorded}, and evidence_missing (= evidence.missing)
///   policy     (with options.policy_dir) {version, sha256, weights, training, curve: [{epoch, train,
///               validation}]} or {error} when the folder holds no readable training record
/// A value without data (no episodes, no latencies) is null.
nlohmann::json summarize(const std::vector<Source>& sources, const ReportOptions& options);

/// Writes report.md, report.html and report.json (the summarize() object) into options.out_dir, plus the
/// plots (success.png, wall_clock.png, with their .dat files, plots.gp and plots.log) when gnuplot runs.
/// Throws std::runtime_error naming the file when out_dir or a report file cannot be written.
ReportFiles render(const std::vector<Source>& sources, const ReportOptions& options);

}  // namespace dh::report
