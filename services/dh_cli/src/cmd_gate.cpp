// `dh gate` (the paired gate of Eq. 6 and the broader round, optionally registered) and `dh registry`.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>

#include "commands.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/evo/attribution.hpp"
#include "dh/evo/gate.hpp"
#include "dh/evo/registry.hpp"
#include "evolution_inputs.hpp"

namespace dh::cli {

std::vector<std::string> broader_round_cells(const std::string& tasks) {
  const auto wanted = tasks.empty() ? std::vector<unsigned>{} : campaign::parse_numbers(tasks, "--tasks");
  std::vector<std::string> cells;
  for (const auto& [name, suite] : load_suites(paths::config_dir()))
    if (std::all_of(wanted.begin(), wanted.end(), [&](unsigned t) { return suite.tasks.count(t) > 0; }))
      cells.push_back(name);
  return cells;
}

nlohmann::json gate_decision(const GateArgs& a) {
  const std::filesystem::path config_file =
      a.config.empty() ? paths::config_dir() / "attribution.yaml" : std::filesystem::path(a.config);
  const evo::AttributionConfig config = evo::load_attribution(config_file);
  const std::string version = cap::load_library_theta(a.library).version;
  // What `dh revise` wrote beside the candidate: κ, the probes, and the parent's version, against which
  // the parent campaign is checked (two databases swapped or of another library are refused).
  nlohmann::json revision;
  const auto revision_file = std::filesystem::path(a.library) / "revision.json";
  if (std::filesystem::exists(revision_file)) {
    try {
      revision = nlohmann::json::parse(std::ifstream(revision_file));
    } catch (const nlohmann::json::exception& e) {
      throw std::invalid_argument(revision_file.string() +
                                  " is not the JSON `dh revise` writes: " + e.what());
    }
  }
  auto parent = evo::gate_rows(arm_rows(a.parent, a.arm), config,
                               revision.is_object() ? revision.value("parent_version", "") : std::string());
  for (auto& r : parent) {
    if (r.contamination.rfind("ran library", 0) == 0)
      throw std::invalid_argument(a.parent + ": " + r.episode.cell + "/" + std::to_string(r.episode.task) +
                                  " seed " + std::to_string(r.episode.seed) + " " + r.contamination +
                                  " (the parent of " + revision_file.string() +
                                  "): not this candidate's parent campaign");
    r.episode.contaminated = false;  // Eq. 6 counts x on the candidate; a parent's lost episode is a failure
  }
  const auto candidate = evo::gate_rows(arm_rows(a.candidate, a.arm), config, version);
  std::vector<evo::GateRow> bare;
  if (!a.bare.empty()) bare = evo::gate_rows(arm_rows(a.bare, a.bare_arm), config, "");
  std::set<evo::CellTask> targeted;
  for (const auto& r : parent)
    if (r.signature && r.signature->capability == a.capability)
      targeted.insert({r.episode.cell, r.episode.task});
  const auto episodes = [](const std::vector<evo::GateRow>& rows) {
    std::vector<evo::GateEpisode> v;
    for (const auto& r : rows) v.push_back(r.episode);
    return v;
  };
  if (targeted.empty())
    throw std::invalid_argument(a.parent + ": no failure of arm " + a.arm + " is attributed to '" +
                                a.capability + "' (dh attribute --db " + a.parent +
                                " lists the signatures): D is empty");
  const evo::GateResult g = evo::paired_gate(episodes(parent), episodes(candidate), episodes(bare), targeted);
  // The broader round, when given: every cell `dh tasks` lists (that has the --tasks), on its own block of seeds.
  std::optional<evo::RegressionResult> regression;
  if (!a.regression_parent.empty() || !a.regression_candidate.empty()) {
    if (a.regression_parent.empty() || a.regression_candidate.empty())
      throw std::invalid_argument(
          "the broader round needs both --regression-parent and --regression-candidate");
    const auto listed = broader_round_cells(a.tasks);
    const std::set<std::string> cells(listed.begin(), listed.end());
    regression = evo::broader_regression(
        episodes(evo::gate_rows(arm_rows(a.regression_parent, a.arm), config, "")),
        episodes(evo::gate_rows(arm_rows(a.regression_candidate, a.arm), config, version)), cells);
  }
  // A candidate that fails the gate is rejected without the broader round; one that passes needs it.
  if (a.register_decision && g.pass && !regression)
    throw std::invalid_argument(
        "--register records a decision, and admitting a candidate that passes the gate needs the broader "
        "round: give --regression-parent and --regression-candidate too");
  const bool admit = g.pass && regression && regression->pass;
  nlohmann::json regression_json = nullptr;
  if (regression)
    regression_json = {{"pass", regression->pass},
                       {"parent", regression->parent},
                       {"candidate", regression->candidate},
                       {"paired", regression->paired},
                       {"contaminated", regression->contaminated},
                       {"lost", regression->lost},
                       {"gained", regression->gained},
                       {"unpaired", regression->unpaired},
                       {"missing_cells", regression->missing_cells}};
  nlohmann::json contaminated = nlohmann::json::array();
  for (const auto& r : candidate)
    if (!r.contamination.empty())
      contaminated.push_back({{"cell", r.episode.cell},
                              {"task", r.episode.task},
                              {"seed", r.episode.seed},
                              {"why", r.contamination}});
  nlohmann::json conditions = nlohmann::json::array(), pairs = nlohmann::json::array();
  for (const auto& c : g.conditions)
    conditions.push_back({{"name", c.name},
                          {"pass", c.pass},
                          {"candidate", c.candidate},
                          {"parent", c.parent},
                          {"detail", c.detail}});
  for (const auto& [d, n] : g.pairs)
    pairs.push_back({{"cell", d.first},
                     {"task", d.second},
                     {"episodes", n.n},
                     {"parent_s", n.parent_s},
                     {"candidate_s", n.candidate_s},
                     {"parent_u", n.parent_u},
                     {"candidate_u", n.candidate_u},
                     {"bare_wins", n.in_pi}});
  nlohmann::json registered = nullptr;
  if (a.register_decision) {
    std::string reason;
    for (const auto& c : g.conditions)
      if (!c.pass)
        reason += (reason.empty() ? "" : "; ") + c.name + " " + std::to_string(c.candidate) + " vs " +
                  std::to_string(c.parent);
    if (!g.unpaired.empty())
      reason += (reason.empty() ? "" : "; ") + std::to_string(g.unpaired.size()) + " unpaired";
    if (regression && !regression->pass) {
      reason += (reason.empty() ? "" : "; ") + fmt::format("broader round {} vs {} successes, {} lost",
                                                           regression->candidate, regression->parent,
                                                           regression->lost.size());
      if (!regression->missing_cells.empty())
        reason += fmt::format(", cells not run: {}", fmt::join(regression->missing_cells, " "));
      if (regression->contaminated) reason += fmt::format(", {} contaminated", regression->contaminated);
      if (!regression->unpaired.empty()) reason += fmt::format(", {} unpaired", regression->unpaired.size());
    }
    nlohmann::json entry{{"capability", a.capability},
                         {"candidate_version", version},
                         {"candidate_library", a.library},
                         {"parent_db", a.parent},
                         {"candidate_db", a.candidate},
                         {"gate", {{"pass", g.pass}, {"conditions", conditions}, {"pairs", pairs}}},
                         {"regression", regression_json},
                         {"reason", admit ? "passed the gate and the broader round" : reason}};
    for (const char* k : {"parent_version", "kappa", "probe", "search"})
      if (revision.contains(k)) entry[k] = revision[k];
    const std::filesystem::path dir =
        a.registry.empty() ? paths::runs_dir() / "registry" : std::filesystem::path(a.registry);
    registered = evo::Registry(dir).append(entry, a.library, admit);
  }
  return {{"pass", g.pass},
          {"capability", a.capability},
          {"candidate_library", version},
          {"conditions", conditions},
          {"pi_vacuous", g.pi_vacuous},
          {"pairs", pairs},
          {"unpaired", g.unpaired},
          {"contaminated", contaminated},
          {"regression", regression_json},
          {"admit", admit},
          {"registered", registered}};
}

int cmd_gate(const GateArgs& a) {
  const nlohmann::json g = gate_decision(a);
  const nlohmann::json& regression = g["regression"];
  const bool pass = g["pass"].get<bool>() && (regression.is_null() || regression["pass"].get<bool>());
  if (a.json) {
    std::cout << g.dump() << "\n";
    return pass ? 0 : 3;
  }
  std::cout << fmt::format("D: {} (cell, task) pair(s) where {}'s failures were attributed\n", g["pairs"].size(),
                           a.capability);
  for (const auto& n : g["pairs"])
    std::cout << fmt::format("  {}/{}  {} episodes  successes {} -> {}  harness failures {} -> {}{}\n",
                             n["cell"].get<std::string>(), n["task"].get<unsigned>(), n["episodes"].get<unsigned>(),
                             n["parent_s"].get<unsigned>(), n["candidate_s"].get<unsigned>(),
                             n["parent_u"].get<unsigned>(), n["candidate_u"].get<unsigned>(),
                             n["bare_wins"].get<bool>() ? "  (the bare arm wins it)" : "");
  for (const auto& c : g["conditions"]) {
    const std::string detail = c["detail"].get<std::string>();
    std::cout << fmt::format("{:<18} {}  candidate {} / parent {}{}\n", c["name"].get<std::string>(),
                             c["pass"].get<bool>() ? "pass" : "FAIL", c["candidate"].dump(), c["parent"].dump(),
                             detail.empty() ? "" : "  (" + detail + ")");
  }
  for (const auto& u : g["unpaired"]) std::cout << "unpaired: the candidate lacks " << u.get<std::string>() << "\n";
  for (const auto& c : g["contaminated"])
    std::cout << "contaminated: " << c["cell"].get<std::string>() << "/" << c["task"] << " seed " << c["seed"]
              << ": " << c["why"].get<std::string>() << "\n";
  std::cout << (g["pass"].get<bool>() ? "the candidate passes the paired gate\n"
                                      : "the candidate fails the paired gate: not admitted\n");
  if (!regression.is_null()) {
    std::cout << fmt::format(
        "broader round: {}  candidate {} / parent {} successes over {} paired episodes ({} lost, "
        "{} gained)\n",
        regression["pass"].get<bool>() ? "pass" : "FAIL", regression["candidate"].dump(), regression["parent"].dump(),
        regression["paired"].dump(), regression["lost"].size(), regression["gained"].size());
    for (const auto& l : regression["lost"]) std::cout << "  lost: " << l.get<std::string>() << "\n";
    for (const auto& c : regression["missing_cells"]) std::cout << "  cell not run: " << c.get<std::string>() << "\n";
    for (const auto& u : regression["unpaired"]) std::cout << "  unpaired: " << u.get<std::string>() << "\n";
  } else {
    std::cout
        << "broader round: not given (admission needs --regression-parent and --regression-candidate)\n";
  }
  const nlohmann::json& registered = g["registered"];
  if (!registered.is_null())
    std::cout << "registered " << registered["id"].get<std::string>() << ": "
              << registered["decision"].get<std::string>()
              << (registered.contains("snapshot")
                      ? " (snapshot " + registered["snapshot"].get<std::string>() + ")"
                      : "")
              << "\n";
  return pass ? 0 : 3;
}

int cmd_registry(const std::string& dir, const std::string& id, bool json) {
  const evo::Registry reg(dir.empty() ? paths::runs_dir() / "registry" : std::filesystem::path(dir));
  if (!id.empty()) {
    const auto e = reg.find(id);
    if (!e) throw std::invalid_argument(reg.file().string() + " has no entry " + id + " (dh registry list)");
    std::cout << e->dump(2) << "\n";
    return 0;
  }
  const auto entries = reg.entries();
  if (json) {
    std::cout << nlohmann::json(entries).dump() << "\n";
    return 0;
  }
  if (entries.empty()) std::cout << reg.file().string() << ": no candidate yet\n";
  for (const auto& e : entries) {
    std::string kappa;
    const nlohmann::json k = e.value("kappa", nlohmann::json::object());
    for (const auto& [name, v] : k.items())
      kappa += fmt::format(" {} {:g}->{:g}", name, v.value("parent", 0.0), v.value("revised", 0.0));
    std::cout << fmt::format("{:<4} {}  {:<8} {:<12} {}{}  ({})\n", e.value("id", ""), e.value("time", ""),
                             e.value("decision", ""), e.value("capability", ""),
                             e.value("candidate_version", ""), kappa, e.value("reason", ""));
  }
  if (const auto cur = reg.current()) std::cout << "current library: " << cur->string() << "\n";
  return 0;
}

}  // namespace dh::cli
