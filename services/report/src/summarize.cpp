#include "dh/report/report.hpp"

#include "dh/common/stats.hpp"
#include "latency.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <tuple>

namespace dh::report {

namespace {

using nlohmann::json;

json number_or_null(double x) { return std::isnan(x) ? json(nullptr) : json(x); }

// Names in the order they first appear.
struct FirstSeen {
  std::vector<std::string> names;
  void see(const std::string& name) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
};

struct Tally {
  unsigned successes = 0, episodes = 0, infrastructure = 0, tick_limit = 0;
  std::vector<stats::ClusteredOutcome> outcomes;  ///< clustered by cell/task
  void add(const EpisodeRecord& r) {
    ++episodes;
    // An infrastructure loss is a failure even if a stale success flag came with it.
    const bool success = r.success && !r.infrastructure;
    successes += success;
    infrastructure += r.infrastructure;
    tick_limit += r.tick_limit;
    outcomes.push_back({r.cluster(), success});
  }
  json to_json(const ReportOptions& options) const {
    const stats::Interval w = stats::wilson(successes, episodes);
    const stats::ClusteredRate c =
        stats::clustered_rate(outcomes, options.bootstrap_resamples, options.bootstrap_seed);
    return {{"successes", successes},
            {"episodes", episodes},
            {"rate", number_or_null(w.point)},
            {"wilson_lo", w.lo},
            {"wilson_hi", w.hi},
            {"cluster_lo", number_or_null(c.interval.lo)},
            {"cluster_hi", number_or_null(c.interval.hi)},
            {"clusters", c.clusters},
            {"infrastructure", infrastructure},
            {"tick_limit", tick_limit}};
  }
};

using PairKey = std::tuple<std::string, unsigned, unsigned>;  // cell, task, seed

json paired_json(const std::vector<stats::PairedOutcome>& outcomes, const ReportOptions& options) {
  const stats::PairedSummary s = stats::paired(outcomes, options.bootstrap_resamples, options.bootstrap_seed);
  const auto pp = [](double x) { return number_or_null(100 * x); };
  return {{"n", s.n},
          {"wins", s.wins_a},
          {"losses", s.wins_b},
          {"ties", s.ties},
          {"diff_pp", pp(s.diff)},
          {"wald_lo_pp", pp(s.wald.lo)},
          {"wald_hi_pp", pp(s.wald.hi)},
          {"bootstrap_lo_pp", pp(s.bootstrap.lo)},
          {"bootstrap_hi_pp", pp(s.bootstrap.hi)},
          {"clusters", s.clusters},
          {"p", s.p}};
}

json paired_comparisons(const std::vector<std::string>& arms, const std::vector<std::string>& cells,
                        const std::map<std::string, std::map<PairKey, bool>>& success_by_key,
                        const ReportOptions& options) {
  json out = json::array();
  for (std::size_t i = 0; i < arms.size(); ++i) {
    for (std::size_t j = i + 1; j < arms.size(); ++j) {
      const auto& a = success_by_key.at(arms[i]);
      const auto& b = success_by_key.at(arms[j]);
      std::vector<stats::PairedOutcome> all;
      std::map<std::string, std::vector<stats::PairedOutcome>> by_cell;
      for (const auto& [key, success_a] : a) {
        const auto it = b.find(key);
        if (it == b.end()) continue;
        const auto& [cell, task, seed] = key;
        stats::PairedOutcome o{EpisodeRecord::cluster_of(cell, task), success_a, it->second};
        all.push_back(o);
        by_cell[cell].push_back(std::move(o));
      }
      json per_cell = json::array();
      for (const std::string& cell : cells) {
        if (!by_cell.contains(cell)) continue;
        json p = paired_json(by_cell[cell], options);
        p["cell"] = cell;
        per_cell.push_back(std::move(p));
      }
      out.push_back(
          {{"a", arms[i]}, {"b", arms[j]}, {"overall", paired_json(all, options)}, {"cells", per_cell}});
    }
  }
  return out;
}

json percentiles_json(const std::vector<double>& ms) {
  const auto q = [&](double at) { return ms.empty() ? json(nullptr) : json(stats::percentile(ms, at)); };
  return {{"count", ms.size()}, {"p50_ms", q(0.5)}, {"p90_ms", q(0.9)}, {"p99_ms", q(0.99)}};
}

json policy_json(const std::filesystem::path& dir) {
  const auto manifest = dir / "train.json";
  std::ifstream in(manifest);
  if (!in) return {{"error", "no " + manifest.string() + ": run `dh train-policy` or pass its output folder"}};
  json p;
  try {
    p = json::parse(in);
  } catch (const json::exception& e) {
    return {{"error", manifest.string() + " is not JSON: " + e.what()}};
  }
  json curve = json::array();
  std::ifstream csv(dir / p.value("loss_curve", "loss.csv"));
  std::string line;
  std::getline(csv, line);  // header
  while (std::getline(csv, line)) {
    std::istringstream row(line);
    std::string epoch, train, validation;
    if (!std::getline(row, epoch, ',') || !std::getline(row, train, ',') || !std::getline(row, validation)) continue;
    try {
      const double v = std::stod(validation);  // "nan" without held-out data
      curve.push_back({{"epoch", std::stoi(epoch)}, {"train", std::stod(train)},
                       {"validation", std::isnan(v) ? json(nullptr) : json(v)}});
    } catch (const std::logic_error&) {  // a torn last line: the curve up to it
    }
  }
  return {{"version", p.value("version", "")}, {"sha256", p.value("sha256", "")}, {"weights", p.value("weights", "")},
          {"training", p.value("training", json::object())}, {"train_seconds", p.value("train_seconds", 0.0)},
          {"curve", curve}};
}

using FailedKey = std::tuple<std::string, std::string, unsigned, unsigned>;  // arm, cell, task, seed

/// Failures by layer per arm and cell, over the rows counted (first of each key) that failed.
json attribution_json(const std::vector<Source>& sources, const std::set<FailedKey>& failed,
                      const std::vector<std::string>& arms, const std::vector<std::string>& cells,
                      const std::map<std::pair<std::string, std::string>, Tally>& tallies, const ReportOptions& options) {
  std::map<FailedKey, const Attributed*> by_key;
  for (const Source& source : sources)
    for (const Attributed& a : source.attributed)
      if (const FailedKey k{a.arm, a.cell, a.task, a.seed}; failed.count(k)) by_key.emplace(k, &a);
  if (by_key.empty()) return {{"config", nullptr}, {"cells", json::array()}};
  json out = json::array();
  for (const std::string& arm : arms)
    for (const std::string& cell : cells) {
      const auto t = tallies.find({arm, cell});
      if (t == tallies.end()) continue;
      std::map<int, std::pair<const Attributed*, unsigned>> layers;
      unsigned attributed = 0, u_d = 0;
      for (const auto& [key, a] : by_key) {
        if (std::get<0>(key) != arm || std::get<1>(key) != cell) continue;
        auto& [first, n] = layers[a->layer];
        first = a;
        ++n;
        ++attributed;
        u_d += a->harness;
      }
      json list = json::array();
      for (const auto& [layer, entry] : layers)
        list.push_back({{"layer", layer}, {"name", entry.first->name}, {"harness", entry.first->harness},
                        {"count", entry.second}});
      out.push_back({{"arm", arm}, {"cell", cell}, {"failed", t->second.episodes - t->second.successes},
                     {"attributed", attributed}, {"layers", list}, {"u_d", u_d}});
    }
  return {{"config", options.attribution_config}, {"cells", out}};
}

// The paper's execution figures for one arm: how episodes end and what their budget went on.
struct Execution {
  std::map<std::string, unsigned> outcomes;  // outcome → episodes ("infrastructure" for a loss)
  std::vector<double> budget_success, budget_failure;  // steps / budget at the end
  std::vector<double> after_progress;       // failures: steps from the last progress to the end
  std::vector<double> success_step, success_wall_s, failure_wall_s;  // wall: losses to infrastructure left out
  unsigned traced = 0, zero_policy = 0;     // episodes with an end in their evidence; none under vla_act
  void add(const EpisodeRecord& r, const EpisodeTrace& t) {
    const bool success = r.success && !r.infrastructure;
    ++outcomes[r.infrastructure ? "infrastructure" : r.outcome.empty() ? "unknown" : r.outcome];
    if (r.budget > 0 && !r.infrastructure)
      (success ? budget_success : budget_failure).push_back(static_cast<double>(r.steps) / r.budget);
    if (!r.infrastructure) (success ? success_wall_s : failure_wall_s).push_back(r.wall_s);
    if (success && r.sim_goal_step >= 0) success_step.push_back(r.sim_goal_step);
    if (t.end_step < 0) return;
    ++traced;
    zero_policy += t.policy_steps == 0;
    if (!success && !r.infrastructure) after_progress.push_back(static_cast<double>(t.end_step - t.last_progress_step));
  }
};

// The verdict from perception against the oracle (the simulator's, LIBERO's rule: the goal held at some
// step), per goal predicate: false success is the perceived verdict latched true where the goal never
// held; false failure is the goal held at some step with the perceived verdict never latched. An episode
// counts under each predicate its goal names.
struct VerdictAgreement {
  std::set<std::string> verifiers;
  std::set<std::string> robots;  ///< the arms the episodes ran on: "panda" for the scenes' own
  struct Counts {
    unsigned episodes = 0, oracle_true = 0, perceived_true = 0, false_success = 0, false_failure = 0;
    std::map<std::string, unsigned> false_success_causes, false_failure_causes;  // by cause(), below
  };
  // What a disagreement comes from, judged at the end: "lost" (a false failure whose goal no longer
  // held), "band" (the bands judge the simulator's own poses as the perceived verdict did: they disagree
  // with its contacts), "perception" (on those poses the bands agree with the oracle, so the perceived
  // poses were wrong; or there was no view at the end), "unknown" (the evidence does not say).
  static std::string cause(const EpisodeTrace& t, bool perceived) {
    if (!perceived && t.oracle_at_end == false) return "lost";
    if (t.unperceived_at_end) return perceived ? "unknown" : "perception";
    if (!t.terms_hold_on_true_poses) return "unknown";
    return *t.terms_hold_on_true_poses == perceived ? "band" : "perception";
  }
  std::map<std::string, Counts> by_predicate;  // "all" too
  void add(const EpisodeRecord& r, const EpisodeTrace& t) {
    if (!t.verifier.empty()) {
      verifiers.insert(t.verifier);
      robots.insert(t.robot.empty() ? "panda" : t.robot);
    }
    // Under the oracle an episode ends at the simulator's verdict, before k perceived frames can follow it:
    // only episodes that ended on the perceived verdict compare the two.
    if (t.verifier != "perception" || !t.perceived || !r.sim_success || r.infrastructure) return;
    auto count = [&](Counts& c) {
      ++c.episodes;
      c.oracle_true += *r.sim_success;
      c.perceived_true += *t.perceived;
      if (*t.perceived && !*r.sim_success) {
        ++c.false_success;
        ++c.false_success_causes[cause(t, true)];
      }
      if (!*t.perceived && *r.sim_success) {
        ++c.false_failure;
        ++c.false_failure_causes[cause(t, false)];
      }
    };
    count(by_predicate["all"]);
    for (const auto& p : std::set<std::string>(t.predicates.begin(), t.predicates.end())) count(by_predicate[p]);
  }
  json to_json(const std::string& arm) const {
    json rows = json::array();
    for (const auto& [predicate, c] : by_predicate) {
      const unsigned oracle_false = c.episodes - c.oracle_true;
      const auto rate = [](unsigned k, unsigned n) {
        if (n == 0) return json{{"k", k}, {"n", n}, {"rate", nullptr}, {"wilson_lo", nullptr}, {"wilson_hi", nullptr}};
        const stats::Interval w = stats::wilson(k, n);
        return json{{"k", k}, {"n", n}, {"rate", static_cast<double>(k) / n}, {"wilson_lo", w.lo}, {"wilson_hi", w.hi}};
      };
      rows.push_back({{"predicate", predicate}, {"episodes", c.episodes}, {"oracle_true", c.oracle_true},
                      {"perceived_true", c.perceived_true}, {"false_success", rate(c.false_success, oracle_false)},
                      {"false_failure", rate(c.false_failure, c.oracle_true)},
                      {"false_success_causes", c.false_success_causes},
                      {"false_failure_causes", c.false_failure_causes}});
    }
    return {{"arm", arm}, {"verifiers", verifiers}, {"robots", robots}, {"predicates", rows}};
  }
};

json quantiles_json(const std::vector<double>& x) {
  const auto q = [&](double at) { return x.empty() ? json(nullptr) : json(stats::percentile(x, at)); };
  const double mean = x.empty() ? NAN : std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  return {{"count", x.size()}, {"p10", q(0.1)}, {"p50", q(0.5)}, {"p90", q(0.9)}, {"mean", number_or_null(mean)}};
}

json execution_json(const std::string& arm, const Execution& e) {
  return {{"arm", arm},
          {"outcomes", e.outcomes},
          {"budget_used", {{"success", quantiles_json(e.budget_success)}, {"failure", quantiles_json(e.budget_failure)}}},
          {"steps_after_progress", quantiles_json(e.after_progress)},
          {"traced", e.traced},
          {"zero_policy_steps", e.zero_policy},
          {"time_to_success", {{"steps", quantiles_json(e.success_step)}}},
          {"wall_s", {{"success", quantiles_json(e.success_wall_s)}, {"failure", quantiles_json(e.failure_wall_s)}}},
          {"budget_used_values",
           {{"success", e.budget_success}, {"failure", e.budget_failure}}}};
}

json wall_clock_json(const std::vector<double>& wall_s) {
  const double total = std::accumulate(wall_s.begin(), wall_s.end(), 0.0);
  return {{"episodes", wall_s.size()},
          {"mean_s", total / static_cast<double>(wall_s.size())},
          {"p50_s", stats::percentile(wall_s, 0.5)},
          {"p90_s", stats::percentile(wall_s, 0.9)},
          {"total_s", total}};
}

}  // namespace

json summarize(const std::vector<Source>& sources, const ReportOptions& options) {
  FirstSeen arms, cells;
  std::map<std::pair<std::string, std::string>, Tally> by_arm_cell;
  std::map<std::string, Tally> by_arm;
  std::map<std::tuple<std::string, std::string, unsigned>, Tally> by_task;
  std::map<std::tuple<std::string, std::string, double>, Tally> by_magnitude;  // "-pos" cells
  std::map<std::pair<std::string, std::string>, std::vector<double>> wall_s;
  std::map<std::string, std::map<PairKey, bool>> success_by_key;
  std::map<std::string, Latencies> latency_by_arm;
  std::map<std::string, Mechanisms> mechanisms_by_arm;
  std::map<std::string, Execution> execution_by_arm;
  std::map<std::string, VerdictAgreement> verdict_by_arm;
  std::set<FailedKey> failed;  // the counted rows that failed
  // Per arm: the episodes that ran without each capability it needs, and those the database does not say.
  std::map<std::string, std::map<std::string, unsigned>> ran_without;
  std::map<std::string, unsigned> capabilities_unknown;
  unsigned rows = 0, duplicates = 0, infrastructure = 0, sim_reported = 0;
  json disagreements = json::array();  // the simulator's own verdict against the governor's
  std::map<EvidenceStatus, unsigned> evidence;
  json source_list = json::array();

  for (const Source& source : sources) {
    source_list.push_back({{"label", source.label}, {"rows", source.rows.size()}});
    for (const EpisodeRecord& r : source.rows) {
      ++rows;
      // A key seen again (overlapping databases) is counted as a duplicate and nowhere else: repeats of
      // one (arm, cell, task, seed) are not independent episodes.
      const bool first = success_by_key[r.arm]
                             .emplace(PairKey{r.cell, r.task, r.seed}, r.success && !r.infrastructure)
                             .second;
      if (!first) {
        ++duplicates;
        continue;
      }
      arms.see(r.arm);
      cells.see(r.cell);
      if (!r.success || r.infrastructure) failed.insert({r.arm, r.cell, r.task, r.seed});
      by_arm_cell[{r.arm, r.cell}].add(r);
      by_arm[r.arm].add(r);
      by_task[{r.arm, r.cell, r.task}].add(r);
      if (const auto p = options.positions.find(r.cell); p != options.positions.end())
        by_magnitude[{r.arm, r.cell, p->second.magnitude_for(r.seed)}].add(r);
      wall_s[{r.arm, r.cell}].push_back(r.wall_s);
      infrastructure += r.infrastructure;
      if (r.capabilities_missing)
        for (const auto& c : *r.capabilities_missing) ++ran_without[r.arm][c];
      else
        ++capabilities_unknown[r.arm];
      sim_reported += r.sim_success.has_value();
      if (r.verdict_disagrees())
        disagreements.push_back({{"arm", r.arm}, {"cell", r.cell}, {"task", r.task}, {"seed", r.seed},
                                 {"governor", r.success}, {"simulator", *r.sim_success},
                                 {"sim_goal_step", r.sim_goal_step}, {"episode_id", r.episode_id}});
      EpisodeTrace trace;
      ++evidence[collect_evidence(r.evidence_path, latency_by_arm[r.arm], mechanisms_by_arm[r.arm], trace)];
      execution_by_arm[r.arm].add(r, trace);
      verdict_by_arm[r.arm].add(r, trace);
    }
  }

  json summary = json::array(), totals = json::array(), tasks = json::array(), wall = json::array();
  json positions = json::array();
  json latency_by = json::array(), mechanisms = json::array(), execution = json::array();
  json verdict_sources = json::array();
  Latencies all_latencies;
  for (const std::string& arm : arms.names) {
    for (const std::string& cell : cells.names) {
      const auto it = by_arm_cell.find({arm, cell});
      if (it == by_arm_cell.end()) continue;
      json s = it->second.to_json(options);
      s["arm"] = arm;
      s["cell"] = cell;
      summary.push_back(std::move(s));
      json w = wall_clock_json(wall_s.at({arm, cell}));
      w["arm"] = arm;
      w["cell"] = cell;
      wall.push_back(std::move(w));
      for (auto t = by_task.lower_bound({arm, cell, 0});
           t != by_task.end() && std::get<0>(t->first) == arm && std::get<1>(t->first) == cell; ++t)
        tasks.push_back({{"arm", arm},
                         {"cell", cell},
                         {"task", std::get<2>(t->first)},
                         {"successes", t->second.successes},
                         {"episodes", t->second.episodes}});
      for (const auto& [key, tally] : by_magnitude)
        if (std::get<0>(key) == arm && std::get<1>(key) == cell) {
          json m = tally.to_json(options);
          m["arm"] = arm;
          m["cell"] = cell;
          m["magnitude"] = std::get<2>(key);
          m["radius_m"] = std::get<2>(key) * options.positions.at(cell).reach_m;
          positions.push_back(std::move(m));
        }
    }
    json total = by_arm.at(arm).to_json(options);
    total["arm"] = arm;
    total["ran_without"] = ran_without[arm];
    total["capabilities_unknown"] = capabilities_unknown[arm];
    totals.push_back(std::move(total));
    const Latencies& l = latency_by_arm.at(arm);
    latency_by.push_back({{"arm", arm},
                          {"decision", percentiles_json(l.decision_ms)},
                          {"planner", percentiles_json(l.planner_ms)}});
    all_latencies.merge(l);
    execution.push_back(execution_json(arm, execution_by_arm.at(arm)));
    verdict_sources.push_back(verdict_by_arm.at(arm).to_json(arm));
    const Mechanisms& m = mechanisms_by_arm.at(arm);
    json commands = json::array();
    unsigned long all_steps = 0;
    for (const auto& [capability, n] : m.steps) all_steps += n;
    for (const auto& [capability, n] : m.commands) {
      const auto st = m.steps.find(capability);
      commands.push_back({{"capability", capability}, {"dispatched", n.first}, {"completed", n.second},
                          {"steps", st == m.steps.end() ? 0ul : st->second}});
    }
    const auto policy = m.steps.find("vla_act");
    const double share = all_steps ? static_cast<double>(policy == m.steps.end() ? 0ul : policy->second) / all_steps : NAN;
    mechanisms.push_back({{"arm", arm}, {"episodes", m.episodes}, {"decisions", m.decisions},
                          {"refusals", m.refusals}, {"commands", commands}, {"steps", all_steps},
                          {"policy_step_share", number_or_null(share)}, {"safety_holds", m.safety_holds},
                          {"episodes_with_hold", m.episodes_held}, {"speed_limited", m.speed_limited},
                          {"speed_limited_share",
                           number_or_null(all_steps ? static_cast<double>(m.speed_limited) / all_steps : NAN)},
                          {"holds_per_episode",
                           number_or_null(m.episodes ? static_cast<double>(m.safety_holds) / m.episodes : NAN)}});
  }

  return {{"title", options.title},
          {"benchmark_note", kBenchmarkNote},
          {"sources", source_list},
          {"rows", rows},
          {"arms", arms.names},
          {"cells", cells.names},
          {"infrastructure", infrastructure},
          {"duplicates", duplicates},
          {"verdict", {{"reported", sim_reported}, {"disagreements", disagreements}, {"by_arm", verdict_sources}}},
          {"summary", summary},
          {"arm_totals", totals},
          {"paired", paired_comparisons(arms.names, cells.names, success_by_key, options)},
          {"bootstrap", {{"resamples", options.bootstrap_resamples}, {"seed", options.bootstrap_seed}}},
          {"attribution", attribution_json(sources, failed, arms.names, cells.names, by_arm_cell, options)},
          {"tasks", tasks},
          {"positions", positions},
          {"wall_clock", wall},
          {"latency",
           {{"decision", percentiles_json(all_latencies.decision_ms)},
            {"planner", percentiles_json(all_latencies.planner_ms)},
            {"unanswered_plan_requests", all_latencies.unanswered},
            {"by_arm", latency_by}}},
          {"mechanisms", mechanisms},
          {"execution", execution},
          {"films", [&] {
             json films = json::array();
             for (const auto& f : options.films) films.push_back({{"file", f.file}, {"caption", f.caption}, {"note", f.note}});
             return films;
           }()},
          {"evidence",
           {{"read", evidence[EvidenceStatus::Read]},
            {"missing", evidence[EvidenceStatus::Missing]},
            {"not_recorded", evidence[EvidenceStatus::NotRecorded]}}},
          {"evidence_missing", evidence[EvidenceStatus::Missing]},
          {"policy", options.policy_dir.empty() ? json(nullptr) : policy_json(options.policy_dir)}};
}

}  // namespace dh::report
