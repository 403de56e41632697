#include "dh/evo/revise.hpp"

#include <algorithm>
#include <boost/random/sobol.hpp>
#include <boost/random/uniform_01.hpp>
#include <chrono>
#include <cmath>
#include <nlopt.hpp>
#include <optional>
#include <stdexcept>

#include "dh/cap/library_theta.hpp"

namespace dh::evo {

namespace {

/// What the three stages share: the probe states, θ's scaling onto [0, 1] and the revision being built.
class Search {
 public:
  Search(Revision& rev, const cap::ThetaRanges& ranges, std::vector<ProbeState> states,
         const ReviseOptions& o)
      : rev_(rev), ranges_(ranges), states_(std::move(states)), o_(o) {
    for (const auto& [name, value] : rev_.parent) {
      const cap::ParameterRange& r = ranges_.at(name);
      names_.push_back(name);
      x0_.push_back((value - r.min) / (r.max - r.min));
    }
    // What the parent holds is the probe set itself: its failing states fail, its successes hold.
    on_set_[rev_.parent] = {rev_.parent_held, 0, rev_.parent_held, false};
    // The round's bound on Subplex: candidates, and probes (each candidate probes the whole set).
    rev_.max_evals = o_.max_evals;
    if (o_.max_probes) rev_.max_evals = std::min(rev_.max_evals, std::max(1u, o_.max_probes / rev_.states));
  }

  /// θ at a point of the unit cube: the parent's own value where the point is the parent's (not its round
  /// trip through the scaling), step counts rounded to whole steps.
  cap::Theta theta_at(const std::vector<double>& at) const {
    cap::Theta th;
    for (std::size_t i = 0; i < names_.size(); ++i) {
      if (at[i] == x0_[i]) {
        th[names_[i]] = rev_.parent.at(names_[i]);
        continue;
      }
      const cap::ParameterRange& r = ranges_.at(names_[i]);
      const double v = r.min + std::clamp(at[i], 0.0, 1.0) * (r.max - r.min);
      th[names_[i]] = r.unit == "steps" ? std::round(v) : v;
    }
    return th;
  }

  /// Scans one parameter at a time, the others at the parent's values, over `scan_levels` levels spread
  /// across its range, on a few failing states spread over the set. Returns the point that held most (the
  /// first of equals), or nothing when none held a single effect.
  std::optional<std::vector<double>> scan() {
    const std::vector<ProbeState> subset = failing_subset();
    rev_.scan_states = static_cast<unsigned>(subset.size());
    std::optional<std::vector<double>> best;
    for (std::size_t i = 0; i < names_.size(); ++i)
      for (unsigned k = 0; k < o_.scan_levels; ++k) {
        const double level = o_.scan_levels == 1 ? 0.5 : static_cast<double>(k) / (o_.scan_levels - 1);
        std::vector<double> at = x0_;
        at[i] = level;
        const cap::Theta th = theta_at(at);
        if (th.at(names_[i]) == rev_.parent.at(names_[i])) continue;  // the parent's own value, already known
        const Held h = held_on(subset, th);
        ++rev_.scanned;
        if (h.held > rev_.scan_best) {
          rev_.scan_best = h.held;
          best = at;
        }
        if (o_.on_scan) o_.on_scan(names_[i], th.at(names_[i]), h.held, rev_.scan_states, rev_.scan_best);
        if (h.held == subset.size()) return best;  // none later can hold more
      }
    return best;
  }

  /// Screens Sobol points over the whole ranges on a few failing states spread over the set's order
  /// (cells, tasks, seeds), not the first few of one task. Returns the point that held most (the first of
  /// equals), or nothing when none held a single effect.
  std::optional<std::vector<double>> screen() {
    const std::vector<ProbeState> subset = failing_subset();
    rev_.screen_states = static_cast<unsigned>(subset.size());
    boost::random::sobol sobol(names_.size());
    boost::random::uniform_01<double> unit;
    std::vector<double> at(names_.size());
    std::optional<std::vector<double>> best;
    for (unsigned k = 0; k < o_.screen; ++k) {
      for (double& v : at) v = unit(sobol);
      const Held h = held_on(subset, theta_at(at));
      ++rev_.screened;
      if (h.held > rev_.screen_best) {
        rev_.screen_best = h.held;
        best = at;
      }
      if (o_.on_screen) o_.on_screen(rev_.screened, o_.screen, h.held, rev_.screen_best);
      if (h.held == subset.size()) break;  // none later can hold more: the first of equals is taken anyway
    }
    return best;
  }

  /// Subplex from `start` on the whole set, within the round's bound; the best θ goes to the revision.
  void subplex(std::vector<double> start) {
    nlopt::opt opt(nlopt::LN_SBPLX, static_cast<unsigned>(names_.size()));
    opt.set_lower_bounds(0.0);
    opt.set_upper_bounds(1.0);
    opt.set_initial_step(0.25);
    opt.set_maxeval(static_cast<int>(rev_.max_evals));
    // Every state holds: nothing left to search for. NLopt stops once the objective passes stopval
    // strictly, and the count reaches the number of states at most.
    opt.set_stopval(rev_.states - 0.5);
    opt.set_max_objective(
        [](const std::vector<double>& at, std::vector<double>&, void* self) {
          return static_cast<double>(static_cast<Search*>(self)->candidate(at).held);
        },
        this);
    double fx = 0;
    try {
      opt.optimize(start, fx);
    } catch (const nlopt::roundoff_limited&) {
      // The fitness is a count: a plateau stops Subplex; what it found stands.
    }
  }

  /// κ as small as the set allows: each changed parameter, the smallest change (in its range) first, goes
  /// back to the parent's value when the set holds as many effects without the change.
  void prune() {
    std::vector<std::pair<double, std::string>> changed;
    for (const auto& [name, value] : rev_.best)
      if (value != rev_.parent.at(name)) {
        const cap::ParameterRange& r = ranges_.at(name);
        changed.emplace_back(std::abs(value - rev_.parent.at(name)) / (r.max - r.min), name);
      }
    std::sort(changed.begin(), changed.end());
    for (const auto& [share, name] : changed) {
      cap::Theta without = rev_.best;
      without[name] = rev_.parent.at(name);
      ++rev_.pruned;
      const Held h = try_on_set(without, true, false);
      rev_.reverted += h.taken;
      if (o_.on_prune) o_.on_prune(name, h.taken, h.held, rev_.best_held);
    }
  }

  /// `at` on the whole set, taken as the best when it holds more than the best so far.
  bool take_if_more(const std::vector<double>& at) { return candidate(at).taken; }

  std::vector<double> parent_point() const { return x0_; }

 private:
  struct Held {
    unsigned held = 0, fixed = 0, kept = 0;
    bool taken = false;  ///< it became the revision's best
  };

  /// The effects `th` holds on `states`: failing states fixed and successes kept.
  Held held_on(const std::vector<ProbeState>& states, const cap::Theta& th) const {
    Held h;
    for (const auto& r : probe_states(states, o_.config_dir, {}, o_.jobs, th, o_.rest, o_.stop)) {
      const bool passed = r.report && r.report->passed();
      h.held += passed;
      (r.state.failing ? h.fixed : h.kept) += passed;
    }
    return h;
  }

  /// A candidate θ of the search on the whole set; one not probed before is counted and reported.
  Held candidate(const std::vector<double>& at) {
    const unsigned before = rev_.evals;
    const Held h = try_on_set(theta_at(at), false, true);
    if (o_.on_eval && rev_.evals != before) o_.on_eval(rev_.evals, rev_.max_evals, h.held, rev_.best_held);
    return h;
  }

  /// Up to `screen_states` failing states, spread over the set's order (cells, tasks, seeds), not the
  /// first few of one task.
  std::vector<ProbeState> failing_subset() const {
    std::vector<ProbeState> failing;
    for (const auto& s : states_)
      if (s.failing) failing.push_back(s);
    std::vector<ProbeState> subset;
    const std::size_t n = std::min<std::size_t>(o_.screen_states, failing.size());
    for (std::size_t i = 0; i < n; ++i) subset.push_back(failing[i * failing.size() / n]);
    return subset;
  }

  /// `th` on the whole set; it becomes the best when it holds more (`or_as_many`: as many). Probes are
  /// deterministic, so a θ met again (the parent's, a scanned start, a step count rounded back to the same
  /// whole step) is not probed again. A `candidate` probed is one of the search's evaluations; the
  /// pruning's are counted apart.
  Held try_on_set(const cap::Theta& th, bool or_as_many, bool candidate) {
    const auto known = on_set_.find(th);
    if (known == on_set_.end() && candidate) ++rev_.evals;
    Held h = known != on_set_.end() ? known->second : on_set_[th] = held_on(states_, th);
    h.taken = h.held > rev_.best_held || (or_as_many && h.held == rev_.best_held);
    if (h.taken) {
      rev_.best = th;
      rev_.best_held = h.held;
      rev_.fixed = h.fixed;
      rev_.kept = h.kept;
    }
    return h;
  }

  Revision& rev_;
  const cap::ThetaRanges& ranges_;
  const std::vector<ProbeState> states_;
  const ReviseOptions& o_;
  std::vector<std::string> names_;
  std::vector<double> x0_;
  std::map<cap::Theta, Held> on_set_;  ///< θ probed on the whole set, and what it held
};

}  // namespace

Revision revise(const std::vector<ProbeOutcome>& set, const ReviseOptions& o) {
  if (set.empty())
    throw std::invalid_argument("the probe set of '" + o.capability + "' is empty: nothing to search on");
  const cap::LibraryTheta lib = cap::load_library_theta(o.library_dir);
  const auto t = lib.theta.find(o.capability);
  if (t == lib.theta.end())
    throw std::invalid_argument("library " + o.library_dir.string() + " has no " + o.capability + ".yaml");
  Revision rev;
  rev.parent = t->second;
  std::vector<ProbeState> states;
  for (const auto& p : set) {
    if (!p.report || p.report->capability != o.capability)
      throw std::invalid_argument(p.state.label + " is not a probed command of '" + o.capability + "'");
    if (nlohmann::json(rev.parent) != p.report->theta)
      throw std::invalid_argument(p.state.label + " recorded θ " + p.report->theta.dump() +
                                  ", not the θ of " + o.library_dir.string() +
                                  ": probe a campaign of the parent library");
    if (p.report->rest.has_value() != o.rest)
      throw std::invalid_argument(p.state.label + (o.rest ? " was probed without" : " was probed with") +
                                  " the rest of its episode, the search " + (o.rest ? "with" : "without"));
    states.push_back(p.state);
    rev.failing += p.state.failing;
    rev.parent_held += p.report->passed();
  }
  rev.states = static_cast<unsigned>(states.size());
  // Unless a screen moves the start, the parent's own point is the first evaluation: the search starts
  // from what the set already holds.
  rev.best = rev.parent;
  rev.best_held = rev.parent_held;
  rev.kept = rev.parent_held;

  const auto t0 = std::chrono::steady_clock::now();
  Search search(rev, lib.ranges.at(o.capability), std::move(states), o);
  std::vector<double> start = search.parent_point();
  // Subplex moves a few parameters at a time from where it starts; a failure one parameter far from the
  // parent's value turns (services/evolution/README.md: the seed-2 library's slide speed) may lie outside its
  // first steps.
  if (rev.failing > 0 && o.scan_levels > 0) {
    auto scanned = search.scan();
    rev.scan_start = scanned && search.take_if_more(*scanned);
    if (rev.scan_start) start = std::move(*scanned);
  }
  if (!rev.scan_start && rev.parent_held == 0 && o.screen > 0) {
    auto screened = search.screen();
    if (!screened) {  // not one effect anywhere screened: Subplex would only walk the plateau
      rev.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return rev;
    }
    start = std::move(*screened);
  }
  search.subplex(std::move(start));
  if (o.prune && rev.improved()) search.prune();
  rev.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& [name, value] : rev.best)
    if (value != rev.parent.at(name)) rev.kappa[name] = {rev.parent.at(name), value};
  return rev;
}

}  // namespace dh::evo
