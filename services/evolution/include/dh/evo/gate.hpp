// The paired gate of Eq. 6 (issue 16). A candidate library ℒ' = ℒ ⊕ κ is compared with its parent ℒ on the
// same episodes (cell, task, seed) of the development seeds, over D, the (cell, task) pairs where the
// parent's failures were attributed to the revised capability (the signature's capability). It passes when
// all four conditions hold:
//   1. Σ_d s_d(ℒ') ≥ Σ_d s_d(ℒ)             successes over D do not fall;
//   2. Σ_d u_d(ℒ') ≤ Σ_d u_d(ℒ)             harness-attributed failures over D do not rise;
//   3. s_d(ℒ') ≥ s_d(ℒ) for every d ∈ D_π   no pair the bare policy wins loses a success;
//   4. x(ℒ') = 0                            no contaminated episode of the candidate in D.
// D_π holds the pairs of D on which the bare arm, on the same seeds, succeeds on more than half; without
// a bare campaign, or when no pair qualifies, condition 3 is vacuous and the result says so. Every
// condition is reported with its numbers. Admission also needs the broader regression (below).
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "dh/common/episode_record.hpp"
#include "dh/evo/attribution.hpp"

namespace dh::evo {

using CellTask = std::pair<std::string, unsigned>;

/// One episode as the gate counts it.
struct GateEpisode {
  std::string cell;
  unsigned task = 0, seed = 0;
  bool success = false;
  bool harness_failure = false;  ///< failed, attributed to a layer with harness: true
  bool contaminated = false;     ///< see contamination()
};

/// Why an episode cannot count: flagged infrastructure, run under another library than `library_version`,
/// or evidence that does not validate (missing, unreadable, or saying another outcome than the campaign
/// recorded). Empty when it counts. `evidence_library` and `evidence_success` are what its evidence says
/// (nullopt when the evidence could not be read).
std::string contamination(const EpisodeRecord& r, const std::string& library_version,
                          const std::optional<std::string>& evidence_library,
                          const std::optional<bool>& evidence_success);

struct GateCondition {
  std::string name;  ///< "successes", "harness_failures", "bare_policy_pairs", "contaminated"
  bool pass = false;
  long candidate = 0, parent = 0;  ///< the two sides compared (for "contaminated": x(ℒ') and 0)
  std::string detail;              ///< the pairs that fail it, or why it is vacuous
};

struct PairCounts {
  unsigned n = 0, parent_s = 0, candidate_s = 0, parent_u = 0, candidate_u = 0;
  bool in_pi = false;
};

struct GateResult {
  bool pass = false;
  std::vector<GateCondition> conditions;  ///< the four, in Eq. 6's order
  bool pi_vacuous = true;
  std::map<CellTask, PairCounts> pairs;  ///< D, with its counts
  std::vector<std::string> unpaired;     ///< episodes of the parent in D the candidate lacks (the gate fails)
};

/// A campaign's episode as the gate reads it, from its row and its evidence.
struct GateRow {
  GateEpisode episode;
  std::optional<Signature> signature;  ///< a failed episode's, when a layer matched
  std::string contamination;           ///< why it does not count ("" when it does or was not checked)
};

/// Reads each row's evidence: a failed episode is attributed under `config` (harness_failure from its
/// layer); with a non-empty `library_version` each episode is checked against it (contamination()).
/// An episode whose evidence does not read is contaminated when checked, else neither success nor
/// harness failure is taken from it beyond its row.
std::vector<GateRow> gate_rows(const std::vector<EpisodeRecord>& rows, const AttributionConfig& config,
                               const std::string& library_version);

/// The capability a revision targets: the one the most harness-attributed failures of `rows` name in
/// their signature, among `revisable` (capabilities with θ); ties go to the first name. Empty when none.
std::string dominant_capability(const std::vector<GateRow>& rows, const std::set<std::string>& revisable);

/// `parent` and `candidate` are the two libraries' episodes, `bare` the bare arm's (may be empty), all on
/// the same seeds; `targeted` is D. Episodes outside D are ignored.
GateResult paired_gate(const std::vector<GateEpisode>& parent, const std::vector<GateEpisode>& candidate,
                       const std::vector<GateEpisode>& bare, const std::set<CellTask>& targeted);

/// The broader regression after the gate: a round over every cell on a separate block of seeds, paired on
/// (cell, task, seed), whose successes must not fall.
struct RegressionResult {
  bool pass = false;
  long parent = 0, candidate = 0;  ///< successes over the paired episodes
  unsigned paired = 0, contaminated = 0;
  std::vector<std::string> lost, gained;   ///< "cell/task seed s" whose success the candidate lost or gained
  std::vector<std::string> unpaired;       ///< parent episodes the candidate lacks
  std::vector<std::string> missing_cells;  ///< of `cells`, those the round did not run
};

/// `cells`: every cell the round must cover (`dh tasks`). It passes when nothing is unpaired or missing,
/// no candidate episode is contaminated, and the candidate's successes are at least the parent's.
RegressionResult broader_regression(const std::vector<GateEpisode>& parent,
                                    const std::vector<GateEpisode>& candidate,
                                    const std::set<std::string>& cells);

}  // namespace dh::evo
