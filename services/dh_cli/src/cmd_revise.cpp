// `dh revise` (the revision search on a probe set) and `dh library perturb` (an untuned library).
#include <fmt/format.h>

#include <algorithm>
#include <ctime>
#include <fstream>
#include <iostream>
#include <set>

#include "commands.hpp"
#include "dh/cap/library.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/evo/attribution.hpp"
#include "dh/evo/gate.hpp"
#include "dh/evo/perturb.hpp"
#include "dh/evo/probe_set.hpp"
#include "dh/evo/revise.hpp"
#include "evolution_inputs.hpp"

namespace dh::cli {

namespace {

/// How the search went: its scan, screen, pruning and candidates, and its wall time.
nlohmann::json search_of(const evo::Revision& rev) {
  return {{"scanned", rev.scanned},         {"scan_states", rev.scan_states},
          {"scan_best", rev.scan_best},     {"scan_start", rev.scan_start},
          {"screened", rev.screened},       {"screen_states", rev.screen_states},
          {"screen_best", rev.screen_best}, {"pruned", rev.pruned},
          {"reverted", rev.reverted},       {"evals", rev.evals},
          {"max_evals", rev.max_evals},     {"wall_s", rev.wall_s}};
}

}  // namespace

nlohmann::json revise_candidate(const ReviseArgs& a, const std::set<std::string>& excluded) {
  const std::vector<EpisodeRecord> rows = arm_rows(a.db, a.arm);
  const unsigned jobs = probe_jobs(a.jobs);
  const std::filesystem::path parent =
      a.library.empty() ? paths::config_dir() / "library" : std::filesystem::path(a.library);
  // Refused before minutes of probing: an --out with files, a capability the library lacks.
  if (!a.out.empty() && std::filesystem::exists(a.out) && !std::filesystem::is_empty(a.out))
    throw std::invalid_argument(a.out + " holds files: give `--out` a new or empty folder");
  const cap::LibraryTheta lib = cap::load_library_theta(parent);
  std::string capability = a.capability;
  if (capability.empty()) {
    // The capability the dominant attributed signature implicates, among those with θ this build runs.
    std::set<std::string> revisable;
    for (const auto& d : cap::all_capabilities())
      if (lib.theta.count(d.name) && !excluded.count(d.name)) revisable.insert(d.name);
    const auto config = evo::load_attribution(paths::config_dir() / "attribution.yaml");
    capability = evo::dominant_capability(evo::gate_rows(rows, config, ""), revisable);
    if (capability.empty())
      throw NothingToRevise(a.db + ": no harness-attributed failure of arm " + a.arm + " names a capability with θ" +
                            (excluded.empty() ? "" : " not tried already") + ": nothing to revise");
    if (!a.json)
      std::cout << "targeting " << capability << ", named by the most harness-attributed failures\n";
  }
  if (!lib.theta.count(capability))
    throw std::invalid_argument("library " + parent.string() + " has no " + capability + ".yaml");
  const evo::ProbeSet set = evo::probe_set(
      rows, {capability, a.successes, a.draw_seed, a.rest, shutdown_requested}, paths::config_dir(), jobs);
  report_skipped(set);
  // Progress on stderr: a search over a large set runs for minutes.
  const char* judged = a.rest ? "episodes won from the state" : "effects held";
  const auto on_eval = [&](unsigned eval, unsigned max_evals, unsigned held, unsigned best) {
    std::cerr << fmt::format("{}: candidate θ {} of at most {}: {} of {} {}, best {}\n", capability, eval, max_evals,
                             held, set.states.size(), judged, best);
  };
  const auto on_screen = [&](unsigned k, unsigned n, unsigned held, unsigned best) {
    std::cerr << fmt::format("{}: the parent holds nothing; screened θ {} of {}: {} of {} {}, best {}\n", capability,
                             k, n, held, std::min<std::size_t>(a.screen_states, set.states.size()), judged, best);
  };
  const auto on_scan = [&](const std::string& parameter, double value, unsigned held, unsigned states,
                           unsigned best) {
    std::cerr << fmt::format("{}: scanned {} = {:g}: {} of {} failing states {}, best {}\n", capability,
                             parameter, value, held, states, judged, best);
  };
  evo::ReviseOptions options;
  options.capability = capability;
  options.config_dir = paths::config_dir();
  options.library_dir = parent;
  options.max_evals = a.max_evals;
  options.jobs = jobs;
  options.max_probes = a.max_probes;
  options.rest = a.rest;
  // Ctrl-C stops the search within the probes at hand (probe_states throws ProbesInterrupted, NLopt ends
  // its run on the throw); the caller tells an interruption from a failure by shutdown_requested().
  options.stop = shutdown_requested;
  options.scan_levels = a.scan_levels;
  options.on_scan = on_scan;
  options.screen = a.screen;
  options.screen_states = a.screen_states;
  options.prune = a.prune;
  options.on_eval = on_eval;
  options.on_screen = on_screen;
  options.on_prune = [&](const std::string& parameter, bool reverted, unsigned held, unsigned best) {
    std::cerr << fmt::format("{}: κ pruned: without {} {} of {} {}, best {}: {}\n", capability, parameter, held,
                             set.states.size(), judged, best, reverted ? "back to the parent's" : "kept");
  };
  const evo::Revision rev = evo::revise(set.states, options);
  nlohmann::json kappa = nlohmann::json::object();
  for (const auto& [name, v] : rev.kappa) kappa[name] = {{"parent", v.first}, {"revised", v.second}};
  std::string out, version;
  if (rev.improved()) {
    std::string note = "candidate of `dh revise --capability " + capability + "` over " + a.db + ":";
    for (const auto& [name, v] : rev.kappa) note += fmt::format(" {} {:g} -> {:g};", name, v.first, v.second);
    const std::filesystem::path dir =
        a.out.empty()
            ? paths::runs_dir() / "candidates" / (capability + "-" + std::to_string(std::time(nullptr)))
            : std::filesystem::path(a.out);
    version = evo::write_library(parent, {{capability, rev.best}}, dir, note);
    out = dir.string();
    // What `dh gate --register` records of the revision: κ, the probe results before and after.
    std::ofstream(dir / "revision.json")
        << nlohmann::json{{"capability", capability},
                          {"db", a.db},
                          {"parent_library", parent.string()},
                          {"parent_version", cap::load_library_theta(parent).version},
                          {"candidate_version", version},
                          {"kappa", kappa},
                          {"probe",
                           {{"judged_by", a.rest ? "rest of the episode" : "effect"},
                            {"states", rev.states},
                            {"failing", rev.failing},
                            {"held_before", rev.parent_held},
                            {"held_after", rev.best_held},
                            {"fixed", rev.fixed},
                            {"kept", rev.kept}}},
                          {"search", search_of(rev)}}
               .dump(2)
        << "\n";
  }
  nlohmann::json r = search_of(rev);
  r.update({{"capability", capability},
            {"states", rev.states},
            {"failing", rev.failing},
            {"parent_held", rev.parent_held},
            {"best_held", rev.best_held},
            {"fixed", rev.fixed},
            {"kept", rev.kept},
            {"kappa", kappa},
            {"out", out},
            {"version", version},
            {"improved", rev.improved()}});
  return r;
}

int cmd_revise(const ReviseArgs& a) {
  install_shutdown_handlers();
  nlohmann::json r;
  try {
    r = revise_candidate(a);
  } catch (...) {
    if (!shutdown_requested()) throw;
    std::cerr << "dh revise: interrupted; nothing was written (the search starts again when run again)\n";
    return 1;
  }
  const bool improved = r["improved"].get<bool>();
  if (a.json) {
    std::cout << r.dump() << "\n";
    return improved ? 0 : 3;
  }
  std::cout << fmt::format("{}: probe set of {} states ({} failing); the parent holds {} effects",
                           r["capability"].get<std::string>(), r["states"].get<unsigned>(),
                           r["failing"].get<unsigned>(), r["parent_held"].get<unsigned>());
  if (r["scanned"].get<unsigned>() > 0)
    std::cout << fmt::format(
        "; {} θ scanned one parameter at a time on {} failing states, the best held {}{}",
        r["scanned"].get<unsigned>(), r["scan_states"].get<unsigned>(), r["scan_best"].get<unsigned>(),
        r["scan_start"].get<bool>() ? " (the search started there)" : "");
  if (r["screened"].get<unsigned>() > 0)
    std::cout << fmt::format("; {} θ screened on {} failing states, the best held {}", r["screened"].get<unsigned>(),
                             r["screen_states"].get<unsigned>(), r["screen_best"].get<unsigned>());
  std::cout << fmt::format("; {} of at most {} candidate θ probed on the set", r["evals"].get<unsigned>(),
                           r["max_evals"].get<unsigned>());
  if (r["pruned"].get<unsigned>() > 0)
    std::cout << fmt::format("; κ pruned: {} of {} changes back to the parent's", r["reverted"].get<unsigned>(),
                             r["pruned"].get<unsigned>());
  std::cout << fmt::format(", in {:.1f} s\n", r["wall_s"].get<double>());
  if (!improved) {
    std::cout << "no θ within the ranges held more effects than the parent's: no candidate\n";
    return 3;
  }
  std::cout << fmt::format("best: {} effects held ({} failing states fixed, {} of {} successes kept); κ:\n",
                           r["best_held"].get<unsigned>(), r["fixed"].get<unsigned>(), r["kept"].get<unsigned>(),
                           r["states"].get<unsigned>() - r["failing"].get<unsigned>());
  for (const auto& [name, v] : r["kappa"].items())
    std::cout << fmt::format("  {} {:g} -> {:g}\n", name, v["parent"].get<double>(), v["revised"].get<double>());
  std::cout << "candidate library " << r["version"].get<std::string>() << " written to " << r["out"].get<std::string>()
            << " (admission is the gate's: run its campaign on the same seeds)\n";
  return 0;
}

int cmd_library_perturb(const std::string& from, std::uint64_t seed, const std::string& out, bool json) {
  const evo::PerturbedLibrary p = evo::perturb_library(from, seed, out);
  if (json) {
    std::cout
        << nlohmann::json{{"version", p.version}, {"out", out}, {"seed", seed}, {"theta", p.theta}}.dump()
        << "\n";
    return 0;
  }
  std::size_t n = 0;
  for (const auto& [capability, theta] : p.theta) n += theta.size();
  std::cout << "library " << p.version << " written to " << out << ": " << n << " parameters of "
            << p.theta.size() << " capabilities drawn within their ranges (seed " << seed << ")\n";
  return 0;
}

}  // namespace dh::cli
