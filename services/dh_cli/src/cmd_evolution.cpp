// The self-evolution commands: `dh probe`, `dh revise`, `dh gate` and `dh library perturb`.
#include <fmt/format.h>

#include <ctime>
#include <set>
#include <iostream>
#include <thread>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/common/paths.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/evo/gate.hpp"
#include "dh/evo/perturb.hpp"
#include "dh/evo/probe.hpp"
#include "dh/evo/probe_set.hpp"
#include "dh/evo/revise.hpp"

namespace dh::cli {

namespace {

int probe_set(const ProbeArgs& a) {
  if (a.capability.empty()) throw std::invalid_argument("--db needs --capability (whose commands to probe)");
  std::vector<EpisodeRecord> rows;
  for (auto& r : campaign::CampaignDb::read_rows(a.db))
    if (r.arm == a.arm) rows.push_back(std::move(r));
  const unsigned jobs = a.jobs ? a.jobs : std::max(1u, std::thread::hardware_concurrency());
  const auto t0 = std::chrono::steady_clock::now();
  const auto parent = evo::probe_set(rows, {a.capability, a.successes, a.draw_seed}, paths::config_dir(), jobs);
  if (parent.empty())
    throw std::invalid_argument(a.db + ": arm " + a.arm + " ran no command of '" + a.capability + "' with evidence");
  std::vector<evo::ProbeState> states;
  for (const auto& p : parent) states.push_back(p.state);
  // Under a candidate library the set is probed again; without one, the parent's probes are the result.
  const auto results = a.library.empty() ? parent : evo::probe_states(states, paths::config_dir(), a.library, jobs);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  unsigned failing = 0, fixed = 0, successes = 0, kept = 0, errors = 0;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& o : results) {
    const bool held = o.report && o.report->effect_held;
    (o.state.failing ? failing : successes)++;
    (o.state.failing ? fixed : kept) += held;
    errors += !o.report;
    nlohmann::json j{{"label", o.state.label}, {"evidence", o.state.evidence}, {"command", o.state.command},
                     {"failing", o.state.failing}, {"effect_held", held}};
    if (o.report) {
      j["state"] = o.report->state;
      j["failure"] = o.report->failure;
      j["reproduces"] = o.report->reproduces;
    } else {
      j["error"] = o.error;
    }
    list.push_back(std::move(j));
    if (!a.json)
      std::cout << fmt::format("{:<40} {:<8} {}\n", o.state.label, o.state.failing ? "failing" : "success",
                               o.report ? o.report->state + (o.report->failure != "none" ? " " + o.report->failure : "") +
                                              (held ? ", effect held" : ", effect not held")
                                        : "error: " + o.error);
  }
  const std::string library = a.library.empty() ? "recorded" : a.library;
  if (a.json) {
    std::cout << nlohmann::json{{"capability", a.capability}, {"library", library}, {"failing", failing},
                                {"fixed", fixed}, {"successes", successes}, {"kept", kept}, {"errors", errors},
                                {"jobs", jobs}, {"wall_s", wall_s}, {"states", list}}
                     .dump()
              << "\n";
  } else {
    std::cout << fmt::format("{} under {}: {} failing state(s), effect held in {}; {} success(es), still held in {}; "
                             "{} error(s); {:.1f} s on {} thread(s)\n",
                             a.capability, library, failing, fixed, successes, kept, errors, wall_s, jobs);
  }
  return errors ? 2 : 0;
}

}  // namespace

int cmd_probe(const ProbeArgs& a) {
  if (!a.db.empty()) return probe_set(a);
  if (a.evidence.empty() || !a.command)
    throw std::invalid_argument("give --evidence FILE --command K (one command) or --db FILE --capability C (a probe set)");
  evo::ProbeReport r;
  try {
    r = evo::probe(a.evidence, {paths::config_dir(), a.library, *a.command, std::nullopt});
  } catch (const std::runtime_error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  const int code = r.effect_held ? 0 : 3;
  if (a.json) {
    std::cout << evo::to_json(r).dump() << "\n";
    return code;
  }
  std::cout << r.episode_id << " command " << *a.command << " (" << r.command_id << ", " << r.capability << ") under "
            << (r.library == "recorded" ? "the recorded θ" : "library " + r.library) << ", from step " << r.from_step
            << ", budget " << r.budget_steps << " steps\n";
  std::cout << "  ended " << r.state << " at step " << r.end_step
            << (r.failure != "none" ? " (" + r.failure + (r.stage.empty() ? "" : " in " + r.stage) + ")" : "")
            << (r.reason.empty() ? "" : ": " + r.reason) << "\n";
  std::cout << "  effect " << r.effect << ": " << (r.effect_held ? "held" : "did not hold") << "\n";
  if (r.recorded)
    std::cout << "  recorded: " << r.recorded->state << " at step " << r.recorded->step
              << (r.recorded->failure != "none" ? " (" + r.recorded->failure + ")" : "") << "\n";
  else
    std::cout << "  recorded: the governor moved on before the command ended\n";
  std::cout << "  " << r.steps_compared << " step(s) compared with the step log: "
            << (r.first_divergence ? "first differs at step " + std::to_string(r.first_divergence->step) + ", " +
                                         r.first_divergence->body + " " + r.first_divergence->quantity
                                   : std::string("identical"))
            << (r.reproduces ? "; the recorded command reproduced bit for bit" : "") << "\n";
  return code;
}

int cmd_revise(const ReviseArgs& a) {
  std::vector<EpisodeRecord> rows;
  for (auto& r : campaign::CampaignDb::read_rows(a.db))
    if (r.arm == a.arm) rows.push_back(std::move(r));
  const unsigned jobs = a.jobs ? a.jobs : std::max(1u, std::thread::hardware_concurrency());
  const auto set = evo::probe_set(rows, {a.capability, a.successes, a.draw_seed}, paths::config_dir(), jobs);
  const std::filesystem::path parent = a.library.empty() ? paths::config_dir() / "library" : std::filesystem::path(a.library);
  const evo::Revision rev = evo::revise(set, {a.capability, paths::config_dir(), parent, a.max_evals, jobs});
  std::string out, version;
  if (rev.improved()) {
    std::string note = "candidate of `dh revise --capability " + a.capability + "` over " + a.db + ":";
    for (const auto& [name, v] : rev.kappa) note += fmt::format(" {} {:g} -> {:g};", name, v.first, v.second);
    const std::filesystem::path dir =
        a.out.empty() ? paths::runs_dir() / "candidates" / (a.capability + "-" + std::to_string(std::time(nullptr)))
                      : std::filesystem::path(a.out);
    version = evo::write_library(parent, {{a.capability, rev.best}}, dir, note);
    out = dir.string();
  }
  if (a.json) {
    nlohmann::json kappa = nlohmann::json::object();
    for (const auto& [name, v] : rev.kappa) kappa[name] = {{"parent", v.first}, {"revised", v.second}};
    std::cout << nlohmann::json{{"capability", a.capability}, {"states", rev.states}, {"failing", rev.failing},
                                {"parent_held", rev.parent_held}, {"best_held", rev.best_held}, {"fixed", rev.fixed},
                                {"kept", rev.kept}, {"evals", rev.evals}, {"max_evals", a.max_evals},
                                {"wall_s", rev.wall_s}, {"kappa", kappa}, {"out", out}, {"version", version}}
                     .dump()
              << "\n";
    return rev.improved() ? 0 : 3;
  }
  std::cout << fmt::format("{}: probe set of {} states ({} failing); the parent holds {} effects; {} of at most {} "
                           "candidate θ probed in {:.1f} s\n",
                           a.capability, rev.states, rev.failing, rev.parent_held, rev.evals, a.max_evals, rev.wall_s);
  if (!rev.improved()) {
    std::cout << "no θ within the ranges held more effects than the parent's: no candidate\n";
    return 3;
  }
  std::cout << fmt::format("best: {} effects held ({} failing states fixed, {} of {} successes kept); κ:\n",
                           rev.best_held, rev.fixed, rev.kept, rev.states - rev.failing);
  for (const auto& [name, v] : rev.kappa) std::cout << fmt::format("  {} {:g} -> {:g}\n", name, v.first, v.second);
  std::cout << "candidate library " << version << " written to " << out
            << " (admission is the gate's: run its campaign on the same seeds)\n";
  return 0;
}

int cmd_gate(const GateArgs& a) {
  const std::filesystem::path config_file =
      a.config.empty() ? paths::config_dir() / "attribution.yaml" : std::filesystem::path(a.config);
  const evo::AttributionConfig config = evo::load_attribution(config_file);
  const auto arm_rows = [](const std::string& db, const std::string& arm) {
    std::vector<EpisodeRecord> rows;
    for (auto& r : campaign::CampaignDb::read_rows(db))
      if (r.arm == arm) rows.push_back(std::move(r));
    if (rows.empty()) throw std::invalid_argument(db + " has no episode of arm " + arm);
    return rows;
  };
  const std::string version = cap::load_library_theta(a.library).version;
  const auto parent = evo::gate_rows(arm_rows(a.parent, a.arm), config, "");
  const auto candidate = evo::gate_rows(arm_rows(a.candidate, a.arm), config, version);
  std::vector<evo::GateRow> bare;
  if (!a.bare.empty()) bare = evo::gate_rows(arm_rows(a.bare, a.bare_arm), config, "");
  std::set<evo::CellTask> targeted;
  for (const auto& r : parent)
    if (r.signature && r.signature->capability == a.capability) targeted.insert({r.episode.cell, r.episode.task});
  const auto episodes = [](const std::vector<evo::GateRow>& rows) {
    std::vector<evo::GateEpisode> v;
    for (const auto& r : rows) v.push_back(r.episode);
    return v;
  };
  const evo::GateResult g = evo::paired_gate(episodes(parent), episodes(candidate), episodes(bare), targeted);
  nlohmann::json contaminated = nlohmann::json::array();
  for (const auto& r : candidate)
    if (!r.contamination.empty())
      contaminated.push_back({{"cell", r.episode.cell}, {"task", r.episode.task}, {"seed", r.episode.seed},
                              {"why", r.contamination}});
  if (a.json) {
    nlohmann::json conditions = nlohmann::json::array(), pairs = nlohmann::json::array();
    for (const auto& c : g.conditions)
      conditions.push_back({{"name", c.name}, {"pass", c.pass}, {"candidate", c.candidate}, {"parent", c.parent},
                            {"detail", c.detail}});
    for (const auto& [d, n] : g.pairs)
      pairs.push_back({{"cell", d.first}, {"task", d.second}, {"episodes", n.n}, {"parent_s", n.parent_s},
                       {"candidate_s", n.candidate_s}, {"parent_u", n.parent_u}, {"candidate_u", n.candidate_u},
                       {"bare_wins", n.in_pi}});
    std::cout << nlohmann::json{{"pass", g.pass}, {"capability", a.capability}, {"candidate_library", version},
                                {"conditions", conditions}, {"pi_vacuous", g.pi_vacuous}, {"pairs", pairs},
                                {"unpaired", g.unpaired}, {"contaminated", contaminated}}
                     .dump()
              << "\n";
    return g.pass ? 0 : 3;
  }
  std::cout << fmt::format("D: {} (cell, task) pair(s) where {}'s failures were attributed\n", g.pairs.size(),
                           a.capability);
  for (const auto& [d, n] : g.pairs)
    std::cout << fmt::format("  {}/{}  {} episodes  successes {} -> {}  harness failures {} -> {}{}\n", d.first,
                             d.second, n.n, n.parent_s, n.candidate_s, n.parent_u, n.candidate_u,
                             n.in_pi ? "  (the bare arm wins it)" : "");
  for (const auto& c : g.conditions)
    std::cout << fmt::format("{:<18} {}  candidate {} / parent {}{}\n", c.name, c.pass ? "pass" : "FAIL", c.candidate,
                             c.parent, c.detail.empty() ? "" : "  (" + c.detail + ")");
  for (const auto& u : g.unpaired) std::cout << "unpaired: the candidate lacks " << u << "\n";
  for (const auto& c : contaminated)
    std::cout << "contaminated: " << c["cell"].get<std::string>() << "/" << c["task"] << " seed " << c["seed"] << ": "
              << c["why"].get<std::string>() << "\n";
  std::cout << (g.pass ? "the candidate passes the paired gate (admission also needs the broader regression)\n"
                       : "the candidate fails the paired gate: not admitted\n");
  return g.pass ? 0 : 3;
}

int cmd_library_perturb(const std::string& from, std::uint64_t seed, const std::string& out, bool json) {
  const evo::PerturbedLibrary p = evo::perturb_library(from, seed, out);
  if (json) {
    std::cout << nlohmann::json{{"version", p.version}, {"out", out}, {"seed", seed}, {"theta", p.theta}}.dump() << "\n";
    return 0;
  }
  std::size_t n = 0;
  for (const auto& [capability, theta] : p.theta) n += theta.size();
  std::cout << "library " << p.version << " written to " << out << ": " << n << " parameters of " << p.theta.size()
            << " capabilities drawn within their ranges (seed " << seed << ")\n";
  return 0;
}

}  // namespace dh::cli
