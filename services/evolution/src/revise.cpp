#include "dh/evo/revise.hpp"

#include <algorithm>
#include <boost/random/sobol.hpp>
#include <boost/random/uniform_01.hpp>
#include <chrono>
#include <cmath>
#include <functional>
#include <nlopt.hpp>
#include <stdexcept>

#include "dh/cap/library_theta.hpp"

namespace dh::evo {

Revision revise(const std::vector<ProbeOutcome>& set, const ReviseOptions& o) {
  if (set.empty())
    throw std::invalid_argument("the probe set of '" + o.capability + "' is empty: nothing to search on");
  const cap::LibraryTheta lib = cap::load_library_theta(o.library_dir);
  const auto t = lib.theta.find(o.capability);
  if (t == lib.theta.end())
    throw std::invalid_argument("library " + o.library_dir.string() + " has no " + o.capability + ".yaml");
  Revision rev;
  rev.parent = t->second;
  const cap::ThetaRanges& ranges = lib.ranges.at(o.capability);
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

  std::vector<std::string> names;
  std::vector<double> x;
  for (const auto& [name, value] : rev.parent) {
    const cap::ParameterRange& r = ranges.at(name);
    names.push_back(name);
    x.push_back((value - r.min) / (r.max - r.min));
  }
  const std::vector<double> x0 = x;
  const auto theta_at = [&](const std::vector<double>& at) {
    cap::Theta th;
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (at[i] == x0[i]) {  // the parent's own value, not its round trip through the scaling
        th[names[i]] = rev.parent.at(names[i]);
        continue;
      }
      const cap::ParameterRange& r = ranges.at(names[i]);
      const double v = r.min + std::clamp(at[i], 0.0, 1.0) * (r.max - r.min);
      th[names[i]] = r.unit == "steps" ? std::round(v) : v;
    }
    return th;
  };
  // Unless a screen moves the start, the parent's own point is the first evaluation: the search starts
  // from what the set already holds.
  rev.best = rev.parent;
  rev.best_held = rev.parent_held;
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  // A θ probed on the whole set; it becomes the best when it holds more (`or_as_many`: as many).
  const auto probe_set_under = [&](const cap::Theta& th, bool or_as_many) {
    unsigned held = 0, fixed = 0, kept = 0;
    for (const auto& r : probe_states(states, o.config_dir, {}, o.jobs, th, o.rest)) {
      const bool h = r.report && r.report->passed();
      held += h;
      (r.state.failing ? fixed : kept) += h;
    }
    const bool better = held > rev.best_held || (or_as_many && held == rev.best_held);
    if (better) {
      rev.best = th;
      rev.best_held = held;
      rev.fixed = fixed;
      rev.kept = kept;
    }
    return std::pair(held, better);
  };
  struct Context {
    std::function<double(const std::vector<double>&)> f;
  } context{[&](const std::vector<double>& at) {
    ++rev.evals;
    const unsigned held = probe_set_under(theta_at(at), false).first;
    if (o.on_eval) o.on_eval(rev.evals, rev.max_evals, held, rev.best_held);
    return static_cast<double>(held);
  }};
  rev.kept = rev.parent_held;
  if (rev.parent_held == 0 && o.screen > 0) {
    // Every state fails under the parent. The screened states are spread over the set's order (cells,
    // tasks, seeds), not the first few of one task.
    std::vector<ProbeState> subset;
    const std::size_t n = std::min<std::size_t>(o.screen_states, states.size());
    for (std::size_t i = 0; i < n; ++i) subset.push_back(states[i * states.size() / n]);
    rev.screen_states = static_cast<unsigned>(n);
    boost::random::sobol sobol(names.size());
    boost::random::uniform_01<double> unit;
    std::vector<double> at(names.size()), best_at;
    for (unsigned k = 0; k < o.screen; ++k) {
      for (double& v : at) v = unit(sobol);
      unsigned held = 0;
      for (const auto& r : probe_states(subset, o.config_dir, {}, o.jobs, theta_at(at), o.rest))
        held += r.report && r.report->passed();
      ++rev.screened;
      if (held > rev.screen_best) {
        rev.screen_best = held;
        best_at = at;
      }
      if (o.on_screen) o.on_screen(rev.screened, o.screen, held, rev.screen_best);
      if (held == subset.size()) break;  // none later can hold more: the first of equals is taken anyway
    }
    if (best_at.empty()) {
      rev.wall_s = elapsed();
      return rev;  // not one effect anywhere screened: Subplex would only walk the plateau
    }
    x = best_at;
  }
  nlopt::opt opt(nlopt::LN_SBPLX, static_cast<unsigned>(names.size()));
  opt.set_lower_bounds(0.0);
  opt.set_upper_bounds(1.0);
  opt.set_initial_step(0.25);
  // A round's bound after any screening: candidates, and probes (each candidate probes the whole set).
  rev.max_evals = o.max_evals;
  if (o.max_probes) rev.max_evals = std::min(rev.max_evals, std::max(1u, o.max_probes / rev.states));
  opt.set_maxeval(static_cast<int>(rev.max_evals));
  // Every state holds: nothing left to search for. NLopt stops once the objective passes stopval
  // strictly, and the count reaches the number of states at most.
  opt.set_stopval(rev.states - 0.5);
  opt.set_max_objective([](const std::vector<double>& at, std::vector<double>&,
                           void* data) { return static_cast<Context*>(data)->f(at); },
                        &context);
  double fx = 0;
  try {
    opt.optimize(x, fx);
  } catch (const nlopt::roundoff_limited&) {
    // The fitness is a count: a plateau stops Subplex; what it found stands.
  }
  if (o.prune && rev.improved()) {
    // κ as small as the set allows: each changed parameter, the smallest change (in its range) first, goes
    // back to the parent's value when the set holds as many effects without the change.
    std::vector<std::pair<double, std::string>> changed;
    for (const auto& [name, value] : rev.best)
      if (value != rev.parent.at(name)) {
        const cap::ParameterRange& r = ranges.at(name);
        changed.emplace_back(std::abs(value - rev.parent.at(name)) / (r.max - r.min), name);
      }
    std::sort(changed.begin(), changed.end());
    for (const auto& [share, name] : changed) {
      cap::Theta without = rev.best;
      without[name] = rev.parent.at(name);
      ++rev.pruned;
      const auto [held, reverted] = probe_set_under(without, true);
      rev.reverted += reverted;
      if (o.on_prune) o.on_prune(name, reverted, held, rev.best_held);
    }
  }
  rev.wall_s = elapsed();
  for (const auto& [name, value] : rev.best)
    if (value != rev.parent.at(name)) rev.kappa[name] = {rev.parent.at(name), value};
  return rev;
}

}  // namespace dh::evo
