// The revision search (issue 16): a derivative-free search over one capability's θ, inside the declared
// physical ranges, whose fitness is its probe set — the failing states whose effect a candidate θ makes
// hold, plus the successes whose effect still holds (with `rest`, the states from which the rest of the
// episode succeeds). NLopt's Subplex (LN_SBPLX) searches the ranges scaled
// to [0, 1] from the parent's θ; step counts are rounded to whole steps. It proposes κ, the parameters
// that changed, so that ℒ' = ℒ ⊕ κ; admission is the gate's, not the search's.
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
  unsigned max_evals = 40;            ///< candidate θ probed at most (the parent's included)
  unsigned jobs = 1;                  ///< probes at once
  unsigned max_probes = 0;            ///< probes at most over the search (0: max_evals × the set's size)
  bool rest = false;                  ///< the set is judged by the rest of each episode (ProbeSetOptions)
  /// Called after each candidate is probed: its number, the bound, the effects it held, the best so far.
  std::function<void(unsigned eval, unsigned max_evals, unsigned held, unsigned best_held)> on_eval;
};

struct Revision {
  cap::Theta parent, best;
  std::map<std::string, std::pair<double, double>> kappa;  ///< parameter -> (parent, revised), changed ones
  unsigned states = 0, failing = 0;
  unsigned parent_held = 0;  ///< states passed under the parent (effects held, or episodes won with rest)
  unsigned best_held = 0, fixed = 0, kept = 0;
  unsigned evals = 0, max_evals = 0;  ///< candidates probed, and the bound the search ran under
  double wall_s = 0;
  bool improved() const { return best_held > parent_held; }
};

/// Searches `options.capability`'s θ on `set` (probe_set's result under the parent). Throws
/// std::invalid_argument when the set is empty, holds another capability's commands, or recorded θ other
/// than the parent library's.
Revision revise(const std::vector<ProbeOutcome>& set, const ReviseOptions& options);

}  // namespace dh::evo
