// `dh evolve`: the self-evolution loop, automatic and resumable (issue 16). Each round runs the current
// library's campaign on the development cells, the revision search on the capability its dominant
// attributed failures name, the candidate's campaign on the same episodes, the paired gate (Eq. 6), and
// for a candidate that passes, the broader round over every cell on the regression block; the registry
// records the decision and an admitted candidate's snapshot is the next round's library. The state lives
// in <out>/evolve.json, written after every stage: a rerun goes on where the last one stopped, and every
// campaign resumes from its database, so no episode runs twice.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/evidence.hpp"
#include "dh/evo/attribution.hpp"
#include "dh/evo/facts.hpp"
#include "dh/evo/registry.hpp"
#include "dh/evo/transfer.hpp"
#include "dh/report/climb.hpp"
#include "dh/sim/scene.hpp"

namespace dh::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// What a resumed climb must share with the one it resumes.
json plan_of(const EvolveArgs& a, const std::string& start_version) {
  json plan{{"start_library", fs::absolute(a.library).lexically_normal().string()},
          {"start_version", start_version},
          {"cells", a.cells},
          {"tasks", a.tasks},
          {"dev_seeds", a.dev_seeds},
          {"regression_seeds", a.regression_seeds},
          {"arm", a.arm},
          {"bare", a.bare},
          {"max_evals", a.max_evals},
          {"screen", a.screen},
          {"prune", a.prune},
          {"successes", a.successes}};
  // With --rest the plan says so; without, it stays as climbs before --rest wrote it, so they resume.
  if (a.rest) plan["rest"] = true;
  if (!a.robot.empty()) plan["robot"] = a.robot;  // likewise
  // Climbs before the scan searched without one; such a climb resumes with --scan-levels 0.
  if (a.scan_levels > 0) plan["scan_levels"] = a.scan_levels;
  return plan;
}

class State {
 public:
  explicit State(fs::path file) : file_(std::move(file)) {
    if (!fs::exists(file_)) return;
    try {
      j_ = json::parse(std::ifstream(file_));
    } catch (const json::exception& e) {
      throw std::invalid_argument(file_.string() + " is not the state `dh evolve` writes (" + e.what() +
                                  "): give another --out, or remove it to start over");
    }
  }
  json& operator*() { return j_; }
  const json& operator*() const { return j_; }
  json* operator->() { return &j_; }
  /// Written whole to a temporary file, then renamed: a kill never leaves half a state.
  void save() const {
    const fs::path tmp = file_.string() + ".tmp";
    std::ofstream(tmp) << j_.dump(2) << "\n";
    fs::rename(tmp, file_);
  }

 private:
  fs::path file_;
  json j_;
};

std::string str(const json& j) { return j.get<std::string>(); }

/// The success rate over a campaign's summary rows (every cell of the arm together).
double success_of(const json& campaign, const std::string& arm) {
  unsigned s = 0, n = 0;
  for (const auto& row : campaign["summary"])
    if (row["arm"] == arm) {
      s += row["successes"].get<unsigned>();
      n += row["episodes"].get<unsigned>();
    }
  return n ? static_cast<double>(s) / n : 0.0;
}

class Climb {
 public:
  Climb(const EvolveArgs& a, fs::path out) : a_(a), out_(std::move(out)), state_(out_ / "evolve.json") {}

  int run() {
    const std::string start_version = cap::load_library_theta(a_.library).version;
    const json plan = plan_of(a_, start_version);
    if (state_->is_null()) {
      *state_ = {{"plan", plan}, {"rounds", json::array()}, {"stop", nullptr}};
      state_.save();
    } else if ((*state_)["plan"] != plan) {
      throw std::invalid_argument((out_ / "evolve.json").string() + " is another climb's (" +
                                  (*state_)["plan"].dump() + "): resume it with its own options or give another --out");
    }
    auto& rounds = (*state_)["rounds"];
    while (rounds.size() < a_.rounds || (!rounds.empty() && rounds.back()["decision"].is_null())) {
      if (!(*state_)["stop"].is_null()) break;
      if (rounds.empty() || !rounds.back()["decision"].is_null()) rounds.push_back(next_round(rounds));
      if (!advance(rounds.back())) {  // the state says where to go on
        if (shutdown_requested())
          std::cerr << fmt::format(
              "dh evolve: interrupted in round {}, at its {} stage; run the same command to go on (recorded "
              "episodes are kept and not run again)\n",
              rounds.back()["round"].get<unsigned>(), str(rounds.back()["stage"]));
        return 1;
      }
      state_.save();
    }
    write_report();
    return print();
  }

 private:
  // A round starts from the last admitted library (and its campaign), or from the last round's library
  // with the capabilities already tried on it excluded.
  json next_round(const json& rounds) const {
    json r{{"round", rounds.size() + 1}, {"stage", "parent"}, {"decision", nullptr}, {"wall_s", 0.0}};
    if (rounds.empty()) {
      r["library"] = fs::absolute(a_.library).lexically_normal().string();
      r["parent_db"] = (out_ / "round-1" / "parent.db").string();
      r["excluded"] = json::array();
      return r;
    }
    const json& last = rounds.back();
    if (last["decision"] == "admitted") {
      r["library"] = last["snapshot"];
      r["parent_db"] = last["candidate_db"];
      r["excluded"] = json::array();
    } else {
      r["library"] = last["library"];
      r["parent_db"] = last["parent_db"];
      r["excluded"] = last["excluded"];
      if (last.contains("capability")) r["excluded"].push_back(last["capability"]);
    }
    return r;
  }

  CampaignArgs campaign(const std::string& arm, const std::string& cells, const std::string& seeds,
                        const std::string& library, const std::string& db) const {
    CampaignArgs c;
    c.arms = arm;
    c.cells = cells;
    c.tasks = a_.tasks;
    c.seeds = seeds;
    c.library = library;
    c.db = db;
    c.launch_file = a_.launch_file;
    c.ready_ms = a_.ready_ms;
    c.robot = a_.robot;
    return c;
  }

  /// Runs a campaign to its end; false when it was interrupted or found no deployment.
  bool run_to_end(const CampaignArgs& c, const std::string& what, json* summary = nullptr) const {
    fs::create_directories(fs::path(c.db).parent_path());
    std::cerr << fmt::format("{}: {} ({} on {}, seeds {}, library {})\n", stage_prefix_, what, c.arms, c.cells,
                             c.seeds, c.library);
    const auto out = run_campaign(c);
    if (!out || (*out)["campaign"]["interrupted"].get<bool>()) return false;
    if (summary) *summary = *out;
    return true;
  }

  std::string all_cells() const {
    std::string cells;
    for (const auto& c : broader_round_cells(a_.tasks)) cells += (cells.empty() ? "" : ",") + c;
    return cells;
  }

  fs::path regression_db(const std::string& version) const { return out_ / "regression" / (version + ".db"); }

  /// Takes the round through its stages; each stage's result is saved before the next starts.
  bool advance(json& r) {
    auto t0 = std::chrono::steady_clock::now();
    const auto n = r["round"].get<unsigned>();
    const fs::path dir = out_ / ("round-" + std::to_string(n));
    fs::create_directories(dir);
    const std::string library = str(r["library"]);
    const auto spent = [&] {
      const auto now = std::chrono::steady_clock::now();
      r["wall_s"] = r["wall_s"].get<double>() + std::chrono::duration<double>(now - t0).count();
      t0 = now;
    };
    stage_prefix_ = fmt::format("round {}/{}", n, a_.rounds);

    if (r["stage"] == "parent") {
      json summary;
      if (!run_to_end(campaign(a_.arm, a_.cells, a_.dev_seeds, library, str(r["parent_db"])), "the library's campaign",
                      &summary))
        return false;
      r["success"] = success_of(summary, a_.arm);
      r["version"] = cap::load_library_theta(library).version;
      if (a_.bare && !run_to_end(campaign("bare", a_.cells, a_.dev_seeds, "", (out_ / "bare.db").string()),
                                 "the bare policy's campaign (the cells it wins, D_pi)"))
        return false;
      r["stage"] = "revise";
      spent();
      state_.save();
    }
    if (r["stage"] == "revise") {
      std::cerr << stage_prefix_ << ": the revision search\n";
      ReviseArgs v;
      v.db = str(r["parent_db"]);
      v.arm = a_.arm;
      v.library = library;
      v.out = (dir / "candidate").string();
      v.max_evals = a_.max_evals;
      v.scan_levels = a_.scan_levels;
      v.screen = a_.screen;
      v.prune = a_.prune;
      v.successes = a_.successes;
      v.rest = a_.rest;
      v.json = true;
      fs::remove_all(v.out);  // a search killed half way wrote nothing the gate reads: it runs again
      std::set<std::string> excluded;
      for (const auto& c : r["excluded"]) excluded.insert(c.get<std::string>());
      try {
        const json rev = revise_candidate(v, excluded);
        r["capability"] = rev["capability"];
        r["revision"] = rev;
      } catch (const NothingToRevise& e) {
        r["decision"] = "none";
        r["reason"] = e.what();
        (*state_)["stop"] = e.what();
        spent();
        return true;
      } catch (...) {
        if (shutdown_requested()) return false;  // interrupted: the search runs again on resume
        throw;
      }
      if (!r["revision"]["improved"].get<bool>()) {
        r["decision"] = "no_candidate";
        r["reason"] = "no θ of " + r["capability"].get<std::string>() + " within its ranges held more effects on the probe set";
        spent();
        return true;
      }
      r["candidate"] = v.out;
      r["candidate_db"] = (dir / "candidate.db").string();
      r["stage"] = "candidate";
      spent();
      state_.save();
    }
    if (r["stage"] == "candidate") {
      json summary;
      if (!run_to_end(campaign(a_.arm, a_.cells, a_.dev_seeds, str(r["candidate"]), str(r["candidate_db"])),
                      "the candidate's campaign on the same episodes", &summary))
        return false;
      r["candidate_success"] = success_of(summary, a_.arm);
      r["stage"] = "gate";
      spent();
      state_.save();
    }
    GateArgs g;
    g.parent = str(r["parent_db"]);
    g.candidate = str(r["candidate_db"]);
    g.library = str(r["candidate"]);
    g.capability = str(r["capability"]);
    g.arm = a_.arm;
    g.tasks = a_.tasks;
    if (a_.bare) g.bare = (out_ / "bare.db").string();
    g.registry = (out_ / "registry").string();
    if (r["stage"] == "gate") {
      std::cerr << stage_prefix_ << ": the paired gate\n";
      const json gate = gate_decision(g);
      r["gate"] = gate;
      r["stage"] = gate["pass"].get<bool>() ? "regression" : "register";
      spent();
      state_.save();
    }
    if (r["stage"] == "regression") {
      const std::string candidate_version = cap::load_library_theta(r["candidate"].get<std::string>()).version;
      const std::string cells = all_cells();
      if (!run_to_end(campaign(a_.arm, cells, a_.regression_seeds, library, regression_db(str(r["version"])).string()),
                      "the broader round, parent") ||
          !run_to_end(campaign(a_.arm, cells, a_.regression_seeds, str(r["candidate"]),
                               regression_db(candidate_version).string()),
                      "the broader round, candidate"))
        return false;
      r["regression_parent_db"] = regression_db(str(r["version"])).string();
      r["regression_candidate_db"] = regression_db(candidate_version).string();
      r["stage"] = "register";
      spent();
      state_.save();
    }
    if (r["stage"] == "register") {
      const std::string candidate_version = cap::load_library_theta(r["candidate"].get<std::string>()).version;
      // A kill between the registry's append and this state's save must not register the candidate twice.
      std::optional<json> entry;
      for (const auto& e : evo::Registry(g.registry).entries())
        if (e.value("candidate_version", "") == candidate_version && e.value("candidate_db", "") == g.candidate)
          entry = e;
      if (!entry) {
        g.register_decision = true;
        if (r.contains("regression_parent_db")) {
          g.regression_parent = str(r["regression_parent_db"]);
          g.regression_candidate = str(r["regression_candidate_db"]);
        }
        entry = gate_decision(g)["registered"];
      }
      r["registry_id"] = (*entry)["id"];
      r["decision"] = (*entry)["decision"];
      r["reason"] = (*entry)["reason"];
      if (entry->contains("snapshot")) r["snapshot"] = (*entry)["snapshot"];
      r["stage"] = "done";
      spent();
    }
    return true;
  }

  /// The success of the last library: the candidate's campaign's when the last round admitted it.
  std::optional<double> final_success() const {
    const auto& rounds = (*state_)["rounds"];
    if (rounds.empty() || !rounds.back().contains("success")) return std::nullopt;
    const json& last = rounds.back();
    return (last["decision"] == "admitted" ? last["candidate_success"] : last["success"]).get<double>();
  }

  void write_report() {
    std::ofstream md(out_ / "evolve.md");
    md << "# Self-evolution climb\n\n"
       << "Start library " << (*state_)["plan"]["start_library"].get<std::string>() << " ("
       << (*state_)["plan"]["start_version"].get<std::string>() << "); arm " << a_.arm << ", cells " << a_.cells
       << ", development seeds " << a_.dev_seeds << ", regression seeds " << a_.regression_seeds
       << (a_.bare ? "" : "; no bare-arm campaign (the gate's third condition is vacuous)") << ".\n\n"
       << "| Round | Library | Success | Capability | κ | Decision | Registry | Wall (s) | Reason |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : (*state_)["rounds"]) {
      std::string kappa;
      if (r.contains("revision"))
        for (const auto& [name, v] : r["revision"]["kappa"].items())
          kappa += fmt::format("{}{} {:g}→{:g}", kappa.empty() ? "" : ", ", name, v["parent"].get<double>(),
                               v["revised"].get<double>());
      md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {:.0f} | {} |\n", r["round"].get<unsigned>(),
                        r.value("version", ""),
                        r.contains("success") ? fmt::format("{:.1f} %", 100 * r["success"].get<double>()) : "",
                        r.value("capability", ""), kappa, r["decision"].is_null() ? "running" : r["decision"].get<std::string>(),
                        r.value("registry_id", ""), r["wall_s"].get<double>(), r.value("reason", ""));
    }
    if (!(*state_)["stop"].is_null()) md << "\nThe climb stopped: " << (*state_)["stop"].get<std::string>() << "\n";
    write_layers(md);
    const std::string why_not = report::draw_climb(climb_points(), out_);
    md << "\n" << (why_not.empty() ? "![The climb](climb.png)" : "No plot of the climb: " + why_not + ".") << "\n";
  }

  /// Each round's library's failed episodes by the first layer that explains them (Eq. 5,
  /// configs/attribution.yaml), from its campaign's evidence; an episode no layer matches, or whose
  /// evidence does not read, is counted apart ("dh attribute --db" names it).
  void write_layers(std::ostream& md) const {
    const auto config = evo::load_attribution(paths::config_dir() / "attribution.yaml");
    md << "\n## Failures by layer, per round\n\nEach round's library on the development seeds; harness layers "
          "(counted by u_d) are marked *.\n\n| Round | Failed |";
    for (const auto& l : config.layers) md << " " << l.name << (l.harness ? "*" : "") << " |";
    md << " unlabelled |\n|---|---|";
    for (std::size_t i = 0; i <= config.layers.size(); ++i) md << "---|";
    md << "\n";
    for (const auto& r : (*state_)["rounds"]) {
      if (!r.contains("success")) break;
      std::vector<unsigned> counts(config.layers.size(), 0);
      unsigned failed = 0, unlabelled = 0;
      for (const EpisodeRecord& e : campaign::CampaignDb::read_rows(str(r["parent_db"]))) {
        if (e.arm != a_.arm || (e.success && !e.infrastructure)) continue;
        ++failed;
        try {
          const std::vector<json> records = fs::exists(e.evidence_path) ? read_evidence(e.evidence_path)
                                                                         : std::vector<json>{};
          const auto label = evo::attribute(evo::read_facts(records, e.infrastructure), config);
          label ? ++counts[static_cast<std::size_t>(label->layer)] : ++unlabelled;
        } catch (const std::exception&) {
          ++unlabelled;
        }
      }
      md << "| " << r["round"].get<unsigned>() << " | " << failed << " |";
      for (unsigned c : counts) md << " " << c << " |";
      md << " " << unlabelled << " |\n";
    }
  }

  /// Each round's library on the development seeds (its parent campaign), then the last admitted
  /// candidate's, with cell × task cluster intervals.
  std::vector<report::ClimbPoint> climb_points() const {
    std::vector<report::ClimbPoint> points;
    const auto point = [&](const std::string& label, const std::string& db, const std::string& decision) {
      std::vector<EpisodeRecord> rows = campaign::CampaignDb::read_rows(db);
      std::erase_if(rows, [&](const EpisodeRecord& r) { return r.arm != a_.arm; });
      const auto rate = evo::clustered_success(rows);
      points.push_back({label, rate.interval.point, rate.interval.lo, rate.interval.hi, decision});
    };
    for (const auto& r : (*state_)["rounds"]) {
      if (!r.contains("success")) break;
      point("round " + std::to_string(r["round"].get<unsigned>()), str(r["parent_db"]),
            r["decision"].is_null() ? "running" : str(r["decision"]));
      if (r["decision"] == "admitted" && &r == &(*state_)["rounds"].back()) point("final", str(r["candidate_db"]), "");
    }
    return points;
  }

  int print() {
    const auto& rounds = (*state_)["rounds"];
    const auto final = final_success();
    if (a_.json) {
      json list = json::array();
      for (const auto& r : rounds) {
        json admitted = json::array(), rejected = json::array();
        if (r["decision"] == "admitted") admitted.push_back(r["registry_id"]);
        if (r["decision"] == "rejected") rejected.push_back(r["registry_id"]);
        list.push_back({{"round", r["round"]},
                        {"library_version", r.value("version", "")},
                        {"success", r.value("success", json())},
                        {"capability", r.value("capability", "")},
                        {"decision", r["decision"]},
                        {"reason", r.value("reason", "")},
                        {"admitted", admitted},
                        {"rejected", rejected},
                        {"wall_s", r["wall_s"]}});
      }
      std::cout << json{{"start_success", rounds.empty() ? json() : rounds.front().value("success", json())},
                        {"final_success", final ? json(*final) : json()},
                        {"rounds", list},
                        {"stop", (*state_)["stop"]},
                        {"registry", (out_ / "registry").string()},
                        {"report", (out_ / "evolve.md").string()}}
                       .dump()
                << "\n";
      return 0;
    }
    for (const auto& r : rounds)
      std::cout << fmt::format("round {}: library {} success {}  {} {}{}\n", r["round"].get<unsigned>(),
                               r.value("version", "?"),
                               r.contains("success") ? fmt::format("{:.1f} %", 100 * r["success"].get<double>()) : "?",
                               r.value("capability", "-"), r["decision"].get<std::string>(),
                               r.contains("reason") ? " (" + r["reason"].get<std::string>() + ")" : "");
    if (final) std::cout << fmt::format("final success {:.1f} %\n", 100 * *final);
    std::cout << "report " << (out_ / "evolve.md").string() << ", registry " << (out_ / "registry").string()
              << " (dh registry list --registry " << (out_ / "registry").string() << ")\n";
    return 0;
  }

  const EvolveArgs& a_;
  fs::path out_;
  State state_;
  std::string stage_prefix_;
};

}  // namespace

int cmd_evolve(const EvolveArgs& a) {
  if (a.library.empty()) throw std::invalid_argument("--library: missing (the library the climb starts from)");
  if (a.rounds == 0) throw std::invalid_argument("--rounds: give at least 1");
  if (!a.robot.empty()) sim::robot_profile(a.robot);  // named before a climb's state holds it
  const fs::path out = a.out.empty() ? paths::runs_dir() / "evolve" : fs::path(a.out);
  fs::create_directories(out);
  install_shutdown_handlers();  // Ctrl-C: the climb stops after the episode or probe at hand
  return Climb(a, out).run();
}

}  // namespace dh::cli
