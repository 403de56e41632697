// The revision search (issue 16): a derivative-free search over one capability's θ, inside the declared
// physical ranges, whose fitness is its probe set — the failing states whose effect a candidate θ makes
// hold, plus the successes whose effect still holds (with `rest`, the states from which the rest of the
// episode succeeds). NLopt's Subplex (LN_SBPLX) searches the ranges scaled
// to [0, 1] from the parent's θ; step counts are rounded to whole steps. It proposes κ, the parameters
// that changed, so that ℒ' = ℒ ⊕ κ; admission is the gate's, not the search's.
//
// Subplex moves a few parameters at a time from where it starts, so a failure that one parameter far from
// the parent's value turns can lie beyond its first steps. When the set has failing states, the search
// first scans one parameter at a time (the others at the parent's values) over a few levels across its
// range, on a few of the failing states; the scanned θ that held most is probed on the whole set, and
// Subplex starts from it when it holds more there than the parent.
//
// A parent that holds nothing on its set (and no scanned θ that holds more) leaves Subplex on a plateau of
// zeros, with no slope to follow and no success to keep near. Such a search first screens θ spread over the
// whole ranges (a Sobol sequence, Boost.Random) on a few of the failing states, and Subplex starts from the θ
// that held most there; when none held a single effect, the search ends without a candidate. A screened θ
// differs from the parent in every parameter; so does a search that wandered. κ is then pruned: each changed
// parameter, the smallest change first, goes back to the parent's value when the whole set holds as many
// effects without it, so that the revision states only what the set needs.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "dh/cap/skill.hpp"
#include "dh/evo/probe_set.hpp"

namespace dh::evo {

struct ReviseOptions {
  std::string capability;
  std::filesystem::path config_dir;
  std::filesystem::path library_dir;  ///< the parent library: its θ must be the one the probe set recorded
  unsigned max_evals = 40;  ///< Subplex's candidate θ at most, its start included (the parent's is known from
                            ///< the set, not probed)
  unsigned jobs = 1;                  ///< probes at once
  unsigned max_probes = 0;  ///< probes at most over the search after any screening (0: max_evals × the set's size)
  bool rest = false;                  ///< the set is judged by the rest of each episode (ProbeSetOptions)
  /// Asked before each probe: true ends the search with ProbesInterrupted (Ctrl-C).
  std::function<bool()> stop = nullptr;
  /// Called after each candidate is probed: its number, the bound, the effects it held, the best so far.
  std::function<void(unsigned eval, unsigned max_evals, unsigned held, unsigned best_held)> on_eval;
  /// Called after each screened θ: its number, how many are screened, the effects it held, the best so far.
  std::function<void(unsigned screened, unsigned screen, unsigned held, unsigned best_held)> on_screen;
  unsigned scan_levels = 4;  ///< levels of each parameter in the one-at-a-time scan (0: no scan)
  /// Called after each scanned θ: the parameter moved, its value, the effects held on how many failing
  /// states, the best so far.
  std::function<void(const std::string& parameter, double value, unsigned held, unsigned states,
                     unsigned best_held)>
      on_scan;
  unsigned screen = 64;               ///< θ screened when the parent holds nothing (0: no screening)
  /// Failing states each scanned or screened θ is probed on, spread over the set.
  unsigned screen_states = 6;
  bool prune = true;                  ///< prune κ after the search (each changed parameter: one probe of the set)
  /// Called after each parameter the pruning tried: whether it went back to the parent's value.
  std::function<void(const std::string& parameter, bool reverted, unsigned held, unsigned best_held)> on_prune;
};

struct Revision {
  cap::Theta parent, best;
  std::map<std::string, std::pair<double, double>> kappa;  ///< parameter -> (parent, revised), changed ones
  unsigned states = 0, failing = 0;
  unsigned parent_held = 0;  ///< states passed under the parent (effects held, or episodes won with rest)
  unsigned best_held = 0, fixed = 0, kept = 0;
  unsigned evals = 0, max_evals = 0;  ///< candidates probed on the whole set, and Subplex's bound
  unsigned scanned = 0;               ///< θ of the one-at-a-time scan
  unsigned scan_states = 0;           ///< failing states each was probed on
  unsigned scan_best = 0;             ///< effects the best scanned θ held on them
  bool scan_start = false;            ///< Subplex started from the best scanned θ (it held more on the set)
  unsigned screened = 0;              ///< θ screened before the search (the parent held nothing)
  unsigned screen_states = 0;         ///< states each was probed on
  unsigned screen_best = 0;           ///< effects the best screened θ held on them
  unsigned pruned = 0;                ///< parameters the pruning tried (one probe of the set each)
  unsigned reverted = 0;              ///< ... of which went back to the parent's value
  double wall_s = 0;
  bool improved() const { return best_held > parent_held; }
};

/// Searches `options.capability`'s θ on `set` (probe_set's result under the parent). Throws
/// std::invalid_argument when the set is empty, holds another capability's commands, or recorded θ other
/// than the parent library's.
Revision revise(const std::vector<ProbeOutcome>& set, const ReviseOptions& options);

}  // namespace dh::evo
