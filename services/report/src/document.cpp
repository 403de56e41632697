#include "document.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>

namespace dh::report {

namespace {

using nlohmann::json;

constexpr const char* kNone = "–";
/// Fewer cell/task clusters than this give no cluster-bootstrap interval in the tables (one cluster gives
/// a zero-width one; a handful say little).
constexpr unsigned kMinClusters = 5;

std::string fixed(const json& x, int decimals) {
  return x.is_number() ? fmt::format("{:.{}f}", x.get<double>(), decimals) : kNone;
}
std::string signed_pp(const json& x) {
  return x.is_number() ? fmt::format("{:+.1f}", x.get<double>()) : kNone;
}
std::string percent(const json& fraction) {
  return fraction.is_number() ? fmt::format("{:.1f} %", 100 * fraction.get<double>()) : kNone;
}
std::string range(const std::string& lo, const std::string& hi) {
  return lo == kNone || hi == kNone ? kNone : "[" + lo + ", " + hi + "]";
}
std::string count(const json& x) { return std::to_string(x.get<unsigned>()); }

// Exact p: three significant digits, scientific below 0.001 (e.g. 2.00e-18).
std::string p_value(double p) { return p < 1e-3 ? fmt::format("{:.2e}", p) : fmt::format("{:.3g}", p); }

bool drawn(const PlotResult& plots, const std::string& file) {
  return std::find(plots.files.begin(), plots.files.end(), file) != plots.files.end();
}

std::vector<std::string> success_row(const json& s, const std::string& cell) {
  const double lo = 100 * s["wilson_lo"].get<double>(), hi = 100 * s["wilson_hi"].get<double>();
  const auto pct = [](const json& x) { return x.is_number() ? json(100 * x.get<double>()) : x; };
  return {s["arm"],
          cell,
          count(s["successes"]),
          count(s["episodes"]),
          percent(s["rate"]),
          range(fixed(lo, 1), fixed(hi, 1)),
          s["clusters"].get<unsigned>() < kMinClusters
              ? std::string(kNone) + " (" + count(s["clusters"]) + ")"
              : range(fixed(pct(s["cluster_lo"]), 1), fixed(pct(s["cluster_hi"]), 1)) + " (" + count(s["clusters"]) + ")",
          count(s["infrastructure"]),
          count(s["tick_limit"])};
}

std::vector<std::string> paired_row(const std::string& scope, const json& p) {
  return {scope,
          count(p["n"]),
          count(p["wins"]),
          count(p["losses"]),
          count(p["ties"]),
          signed_pp(p["diff_pp"]),
          range(fixed(p["wald_lo_pp"], 1), fixed(p["wald_hi_pp"], 1)),
          range(fixed(p["bootstrap_lo_pp"], 1), fixed(p["bootstrap_hi_pp"], 1)),
          p_value(p["p"].get<double>())};
}

std::vector<std::string> latency_row(const std::string& arm, const std::string& kind, const json& l) {
  return {arm, kind, count(l["count"]), fixed(l["p50_ms"], 3), fixed(l["p90_ms"], 3), fixed(l["p99_ms"], 3)};
}

void overview(const json& s, Document& doc) {
  std::string sources;
  for (const json& src : s["sources"])
    sources +=
        (sources.empty() ? "" : ", ") + src["label"].get<std::string>() + " (" + count(src["rows"]) + ")";
  doc.push_back(Paragraph{count(s["rows"]) + " episodes from " + std::to_string(s["sources"].size()) +
                          " database(s): " + (sources.empty() ? kNone : sources) + "."});
  doc.push_back(Paragraph{"Episodes lost to infrastructure: " + count(s["infrastructure"]) +
                          " (each counted as a failure in every denominator)."});
  if (s["duplicates"].get<unsigned>() > 0)
    doc.push_back(
        Paragraph{"Warning: " + count(s["duplicates"]) +
                  " episode(s) repeat an (arm, cell, task, seed) key already seen; only the first row of "
                  "a key counts anywhere in this report."});
  const json& v = s["verdict"];
  doc.push_back(Paragraph{"The simulator's own verdict (LIBERO's rule: the goal held at some step), recorded apart "
                          "from the governor's: reported for " +
                          count(v["reported"]) + " of " + count(s["rows"]) +
                          " episodes; it disagrees with the governor's on " +
                          std::to_string(v["disagreements"].size()) + "."});
  if (!v["disagreements"].empty()) {
    Table t{{"Arm", "Cell", "Task", "Seed", "Governor", "Simulator", "Goal first held at step", "Episode"}, {}};
    for (const json& d : v["disagreements"]) {
      const int at = d["sim_goal_step"].get<int>();
      t.rows.push_back({d["arm"].get<std::string>(), d["cell"].get<std::string>(), count(d["task"]),
                        count(d["seed"]), d["governor"].get<bool>() ? "success" : "failure",
                        d["simulator"].get<bool>() ? "success" : "failure", at < 0 ? kNone : std::to_string(at),
                        d["episode_id"].get<std::string>()});
    }
    doc.push_back(std::move(t));
  }
  // Which verdict each arm's episodes ended on, and, where perception judged the goal too, how its verdict
  // agrees with the simulator's.
  std::string sources_of_verdict, robots;
  Table agreement{{"Arm", "Predicate", "Episodes", "Oracle true", "Perceived true", "False success (%)",
                   "Wilson 95 % (%)", "By cause", "False failure (%)", "Wilson 95 % (%)", "By cause"},
                  {}};
  for (const json& a : v["by_arm"]) {
    // "arm: x and y" from the arm's list `key`, added to `into` after a "; ".
    const auto add = [&a](std::string& into, const char* key) {
      std::string names;
      for (const json& name : a[key]) names += (names.empty() ? "" : " and ") + name.get<std::string>();
      into += (into.empty() ? "" : "; ") + a["arm"].get<std::string>() + ": " +
              (names.empty() ? "unknown (no evidence read)" : names);
    };
    add(sources_of_verdict, "verifiers");
    add(robots, "robots");
    const auto pct = [](const json& r) { return r["rate"].is_null() ? kNone : fixed(100.0 * r["rate"].get<double>(), 1); };
    const auto ci = [](const json& r) {
      return r["rate"].is_null() ? kNone
                                 : range(fixed(100.0 * r["wilson_lo"].get<double>(), 1), fixed(100.0 * r["wilson_hi"].get<double>(), 1));
    };
    const auto causes = [](const json& c) {
      std::string text;
      for (const auto& [cause, k] : c.items()) text += (text.empty() ? "" : ", ") + cause + " " + count(k);
      return text.empty() ? kNone : text;
    };
    for (const json& p : a["predicates"])
      agreement.rows.push_back({a["arm"].get<std::string>(), p["predicate"].get<std::string>(), count(p["episodes"]),
                                count(p["oracle_true"]), count(p["perceived_true"]),
                                pct(p["false_success"]) + " (" + count(p["false_success"]["k"]) + "/" + count(p["false_success"]["n"]) + ")",
                                ci(p["false_success"]), causes(p["false_success_causes"]),
                                pct(p["false_failure"]) + " (" + count(p["false_failure"]["k"]) + "/" + count(p["false_failure"]["n"]) + ")",
                                ci(p["false_failure"]), causes(p["false_failure_causes"])});
  }
  doc.push_back(Paragraph{"The verdict each arm's episodes ended on (oracle: the simulator's; perception: the goal "
                          "judged on perceived frames): " + (sources_of_verdict.empty() ? kNone : sources_of_verdict) +
                          ". The robot they ran on: " + (robots.empty() ? kNone : robots) + "."});
  if (!agreement.rows.empty()) {
    doc.push_back(Paragraph{"The verdict from perception against the simulator's, over the episodes that ended on "
                            "it (under the oracle an episode ends before its perceived frames can follow), per "
                            "goal predicate (an episode counts under each predicate its goal names). False success: the perceived verdict "
                            "latched true where the goal never held (of those episodes). False failure: the goal held at some step and the perceived verdict "
                            "never latched (of the episodes where it held). Their causes, from the goal's terms judged "
                            "at the end both as perceived and on the simulator's own poses: lost (a false failure "
                            "whose goal no longer held at the end), band (on the simulator's poses the perceived "
                            "verdict's bands say what perception said: they disagree with the simulator's "
                            "contacts), perception (on those poses the bands agree with the simulator: the "
                            "perceived poses were wrong, or there was no view at the end), unknown (the evidence "
                            "does not say). Articulated parts' joints are perceived when the perception service ran with a parts camera (--parts-camera), else the values the cell reported."});
    doc.push_back(std::move(agreement));
  }
  const json& e = s["evidence"];
  doc.push_back(Paragraph{"Evidence files read: " + count(e["read"]) + "; missing or unreadable: " +
                          count(e["missing"]) + "; not recorded: " + count(e["not_recorded"]) + "."});
}

// An arm that ran without a capability it needs is another arm in effect (`full` without `vla_act` is
// `no-vla`): said under the table, never left to the evidence.
void ran_without(const json& total, Document& doc) {
  const std::string arm = total["arm"];
  const auto episodes = total["episodes"].get<unsigned>();
  for (const auto& [capability, n] : total["ran_without"].items())
    doc.push_back(Paragraph{fmt::format(
        "Warning: {} ran without {} in {} of its {} episodes: no live instance of it when they started (for "
        "`vla_act`, `dh train-policy` trains the embedded policy). Those episodes measure the arm without "
        "it.",
        arm, capability, count(n), episodes)});
  if (const auto unknown = total["capabilities_unknown"].get<unsigned>(); unknown > 0)
    doc.push_back(Paragraph{fmt::format(
        "For {} of {}'s {} episodes the database does not say whether every capability the arm needs was "
        "live "
        "(lost before a result, or recorded before campaign databases kept it); their evidence does "
        "(`capabilities_missing`).",
        unknown, arm, episodes)});
}

void success(const json& s, const PlotResult& plots, Document& doc) {
  doc.push_back(Heading{2, "Success per arm and cell"});
  doc.push_back(Paragraph{fmt::format(
      "Wilson treats every episode as independent. A task's seeds only jitter one layout, so beside it stands "
      "the 95 % percentile interval of a bootstrap over whole cell/task clusters ({} resamples, seed {}; in "
      "brackets, the number of clusters; none below {} clusters). Where the two differ, the episodes are not "
      "independent draws; with about ten clusters a percentile bootstrap is itself somewhat too narrow.",
      count(s["bootstrap"]["resamples"]), s["bootstrap"]["seed"].get<std::uint64_t>(), kMinClusters)});
  Table t{{"Arm", "Cell", "Successes", "Episodes", "Rate", "Wilson 95 % (%)", "Cell/task bootstrap 95 % (%)",
           "Infrastructure", "Tick limit"},
          {}};
  for (const json& total : s["arm_totals"]) {
    for (const json& row : s["summary"])
      if (row["arm"] == total["arm"]) t.rows.push_back(success_row(row, row["cell"]));
    t.rows.push_back(success_row(total, "all"));
  }
  doc.push_back(std::move(t));
  for (const json& total : s["arm_totals"]) ran_without(total, doc);
  if (drawn(plots, "success.png")) doc.push_back(Image{"success.png", "Success rate per arm and cell"});
}

void comparisons(const json& s, Document& doc) {
  doc.push_back(Heading{2, "Paired comparisons"});
  doc.push_back(Paragraph{fmt::format(
      "Pairs are the (cell, task, seed) keys both arms ran. W: A succeeded and B failed; L: the reverse. "
      "Δ: success of A minus B in percentage points. Paired Wald: Δ ± 1.96·sd(d)/√n over the per-episode "
      "differences d. Cell bootstrap: 95 % percentile interval over {} resamples of whole cell/task "
      "clusters (seed {}). p: exact two-sided sign test over W + L.",
      count(s["bootstrap"]["resamples"]), s["bootstrap"]["seed"].get<std::uint64_t>())});
  if (s["paired"].empty()) doc.push_back(Paragraph{"Fewer than two arms: nothing to compare."});
  for (const json& pair : s["paired"]) {
    doc.push_back(
        Heading{3, "A = " + pair["a"].get<std::string>() + " vs B = " + pair["b"].get<std::string>()});
    Table t{{"Cell", "n", "W", "L", "Ties", "Δ pp", "Paired Wald 95 % (pp)", "Cell bootstrap 95 % (pp)", "p"},
            {paired_row("all", pair["overall"])}};
    for (const json& c : pair["cells"]) t.rows.push_back(paired_row(c["cell"], c));
    doc.push_back(std::move(t));
  }
}

void per_task(const json& s, Document& doc) {
  doc.push_back(Heading{2, "Per-task success"});
  for (const json& cell : s["cells"]) {
    doc.push_back(Heading{3, cell.get<std::string>()});
    std::vector<unsigned> tasks;
    for (const json& t : s["tasks"])
      if (t["cell"] == cell) tasks.push_back(t["task"]);
    std::sort(tasks.begin(), tasks.end());
    tasks.erase(std::unique(tasks.begin(), tasks.end()), tasks.end());
    Table table{{"Task"}, {}};
    for (const json& arm : s["arms"]) table.header.push_back(arm);
    for (unsigned task : tasks) {
      std::vector<std::string> row{std::to_string(task)};
      for (const json& arm : s["arms"]) {
        std::string cell_text = kNone;
        for (const json& t : s["tasks"])
          if (t["arm"] == arm && t["cell"] == cell && t["task"] == task)
            cell_text = count(t["successes"]) + "/" + count(t["episodes"]);
        row.push_back(cell_text);
      }
      table.rows.push_back(std::move(row));
    }
    doc.push_back(std::move(table));
  }
}

void positions(const json& s, const PlotResult& plots, Document& doc) {
  if (s["positions"].empty()) return;
  doc.push_back(Heading{2, "Success against displacement (-pos cells)"});
  doc.push_back(Paragraph{
      "Each free object stood anywhere within the radius of its place that the seed's magnitude gave "
      "(configs/suites/pos/positions.yaml); the seed picks the magnitude, so each row holds every fifth seed."});
  Table t{{"Arm", "Cell", "Magnitude", "Radius (m)", "Successes", "Episodes", "Rate", "Wilson 95 %",
           "Cell/task clusters 95 % (clusters)", "Infrastructure", "Tick limit"},
          {}};
  for (const json& p : s["positions"]) {
    std::vector<std::string> row = success_row(p, p["cell"]);
    row.insert(row.begin() + 2, {"x" + fixed(p["magnitude"], 1), fixed(p["radius_m"], 2)});
    t.rows.push_back(std::move(row));
  }
  doc.push_back(std::move(t));
  if (drawn(plots, "positions.png"))
    doc.push_back(Image{"positions.png", "Success against the displacement radius (Wilson 95 % intervals)"});
}

void wall_clock(const json& s, const PlotResult& plots, Document& doc) {
  doc.push_back(Heading{2, "Episode wall clock"});
  Table t{{"Arm", "Cell", "Episodes", "Mean (s)", "p50 (s)", "p90 (s)", "Total (s)"}, {}};
  for (const json& w : s["wall_clock"])
    t.rows.push_back({w["arm"], w["cell"], count(w["episodes"]), fixed(w["mean_s"], 2), fixed(w["p50_s"], 2),
                      fixed(w["p90_s"], 2), fixed(w["total_s"], 1)});
  doc.push_back(std::move(t));
  if (drawn(plots, "wall_clock.png"))
    doc.push_back(Image{"wall_clock.png", "Episode wall clock per arm and cell"});
}

void latency(const json& s, Document& doc) {
  const json& l = s["latency"];
  doc.push_back(Heading{2, "Latency"});
  doc.push_back(
      Paragraph{"Decision: the governor's time from observation or event to decision (latency_ns of "
                "decision records). Planner: plan_request to the advice with the same request_id. "
                "Plan requests never answered: " +
                count(l["unanswered_plan_requests"]) + "."});
  Table t{{"Arm", "Kind", "Count", "p50 (ms)", "p90 (ms)", "p99 (ms)"},
          {latency_row("all", "decision", l["decision"]), latency_row("all", "planner", l["planner"])}};
  for (const json& a : l["by_arm"]) {
    t.rows.push_back(latency_row(a["arm"], "decision", a["decision"]));
    t.rows.push_back(latency_row(a["arm"], "planner", a["planner"]));
  }
  doc.push_back(std::move(t));
}

void mechanisms(const json& s, Document& doc) {
  doc.push_back(Heading{2, "Execution mechanisms"});
  doc.push_back(Paragraph{
      "From the evidence files: how often the fast brain substituted a capability, inserted a recovery, "
      "resumed after one, retried, replanned after a failure or stagnation, asked for the next step after a "
      "completion, or moved on in a frozen plan; refusals count grounding refusals and capabilities that "
      "refused before moving. Counts are totals over the arm's episodes."});
  const std::vector<std::string> kinds{"substitute", "insert_recovery", "resume", "retry", "hand_to_vla",
                                       "request_replan", "next_step", "next_in_sequence"};
  Table t{{"Arm", "Episodes", "Refusals"}, {}};
  for (const auto& k : kinds) t.header.push_back(k);
  for (const json& m : s["mechanisms"]) {
    std::vector<std::string> row{m["arm"], count(m["episodes"]), count(m["refusals"])};
    for (const auto& k : kinds) row.push_back(count(m["decisions"].value(k, 0u)));
    t.rows.push_back(std::move(row));
  }
  doc.push_back(std::move(t));
  Table c{{"Arm", "Capability", "Dispatched", "Completed", "Steps in control"}, {}};
  for (const json& m : s["mechanisms"])
    for (const json& k : m["commands"])
      c.rows.push_back({m["arm"], k["capability"], count(k["dispatched"]), count(k["completed"]), count(k["steps"])});
  doc.push_back(std::move(c));
  doc.push_back(Paragraph{
      "Share of control steps under the policy (vla_act), from each dispatch to the next dispatch or the "
      "episode's end:"});
  Table p{{"Arm", "Steps", "Under vla_act"}, {}};
  for (const json& m : s["mechanisms"])
    p.rows.push_back({m["arm"], count(m["steps"]), percent(m["policy_step_share"])});
  doc.push_back(std::move(p));
  doc.push_back(Paragraph{
      "Safety holds: the seam's 50 Hz envelope holding the arm because a joint would exceed its speed "
      "limit (the seam's `safety_hold` events in the evidence). Beneath it the arm controller's speed limiter "
      "brakes a joint above 0.9 of that limit, so a hold is a fault signal; the limiter's steps are counted "
      "(`speed_limited`, share of the control steps under commands; docs/controller.md)."});
  Table h{{"Arm", "Episodes", "Safety holds", "Episodes with a hold", "Holds per episode", "Speed-limited steps",
           "Share of steps"},
          {}};
  for (const json& m : s["mechanisms"])
    h.rows.push_back({m["arm"], count(m["episodes"]), count(m["safety_holds"]), count(m["episodes_with_hold"]),
                      fixed(m["holds_per_episode"], 2), count(m["speed_limited"]), percent(m["speed_limited_share"])});
  doc.push_back(std::move(h));
}

void policy(const json& s, Document& doc) {
  const json& p = s["policy"];
  if (p.is_null()) return;
  doc.push_back(Heading{2, "Embedded policy (vla_act)"});
  if (p.contains("error")) {
    doc.push_back(Paragraph{p["error"].get<std::string>()});
    return;
  }
  const json& t = p["training"];
  const json& d = t.value("demonstrations", json::object());
  doc.push_back(Paragraph{fmt::format(
      "Weights {} ({}), SHA-256 {}. Behaviour cloning of the analytic capabilities: {} demonstrations ({} steps), "
      "MLP hidden {}, {} actions per inference, {} epochs, seed {}, {} training and {} held-out samples; "
      "trained in {:.0f} s.",
      p.value("weights", ""), p.value("version", ""), p.value("sha256", ""), d.value("demonstrations", 0),
      d.value("steps", 0), t.value("hidden", json::array()).dump(), t.value("chunk", 0), t.value("epochs", 0),
      t.value("seed", 0),
      t.value("train_samples", 0), t.value("validation_samples", 0), p.value("train_seconds", 0.0))});
  Table c{{"Epoch", "Train MSE", "Held-out MSE"}, {}};
  for (const json& e : p["curve"])
    c.rows.push_back({std::to_string(e["epoch"].get<int>()), fixed(e["train"], 5), fixed(e["validation"], 5)});
  doc.push_back(std::move(c));
}

void attribution(const json& s, Document& doc) {
  doc.push_back(Heading{2, "Failures by layer"});
  const json& a = s["attribution"];
  if (a["cells"].empty()) {
    doc.push_back(Paragraph{"No attribution stored for these databases: run `dh attribute --db FILE` first."});
    return;
  }
  doc.push_back(Paragraph{"Each failed episode carries the first layer, upstream first, whose check holds on its "
                          "evidence (`dh attribute`, configuration " + a["config"].get<std::string>() +
                          "). u_d: the failures the harness owns (layers marked harness)."});
  Table t{{"Arm", "Cell", "Failed", "Attributed", "By layer", "u_d"}, {}};
  for (const json& c : a["cells"]) {
    std::string layers;
    for (const json& l : c["layers"])
      layers += (layers.empty() ? "" : ", ") + l["name"].get<std::string>() + " " + count(l["count"]);
    t.rows.push_back({c["arm"], c["cell"], count(c["failed"]), count(c["attributed"]), layers.empty() ? kNone : layers,
                      count(c["u_d"])});
  }
  doc.push_back(std::move(t));
}

// p50 [p10, p90] of a quantiles object, scaled (100 for a fraction shown in %).
std::string spread(const json& q, double scale, int decimals) {
  if (!q["p50"].is_number()) return kNone;
  const auto v = [&](const char* k) { return fmt::format("{:.{}f}", scale * q[k].get<double>(), decimals); };
  return v("p50") + " [" + v("p10") + ", " + v("p90") + "] (" + count(q["count"]) + ")";
}

void execution(const json& s, const PlotResult& plots, Document& doc) {
  doc.push_back(Heading{2, "Execution figures"});
  doc.push_back(Paragraph{
      "How episodes end (the outcome composition; a loss to infrastructure is a failure in every rate) and "
      "what their budget went on. Figures are p50 [p10, p90] (episodes)."});
  std::vector<std::string> outcomes{"success", "budget_exhausted", "gave_up", "infrastructure"};
  for (const json& e : s["execution"])
    for (const auto& [o, n] : e["outcomes"].items())
      if (std::find(outcomes.begin(), outcomes.end(), o) == outcomes.end()) outcomes.push_back(o);
  Table c{{"Arm"}, {}};
  for (const auto& o : outcomes) c.header.push_back(o);
  for (const json& e : s["execution"]) {
    std::vector<std::string> row{e["arm"]};
    for (const auto& o : outcomes) row.push_back(count(e["outcomes"].value(o, 0u)));
    c.rows.push_back(std::move(row));
  }
  doc.push_back(std::move(c));
  Table b{{"Arm", "Budget used, successes (%)", "Budget used, failures (%)", "Failures: steps after the last progress",
           "Episodes never under vla_act"},
          {}};
  for (const json& e : s["execution"])
    b.rows.push_back({e["arm"], spread(e["budget_used"]["success"], 100, 0), spread(e["budget_used"]["failure"], 100, 0),
                      spread(e["steps_after_progress"], 1, 0),
                      count(e["zero_policy_steps"]) + " of " + count(e["traced"])});
  doc.push_back(std::move(b));
  if (drawn(plots, "budget.png"))
    doc.push_back(Image{"budget.png", "Budget used at the episode's end, by arm and outcome"});
  Table t{{"Arm", "Time to success (steps)", "Wall clock, successes (s)", "Wall clock, failures (s)"}, {}};
  for (const json& e : s["execution"])
    t.rows.push_back({e["arm"], spread(e["time_to_success"]["steps"], 1, 0), spread(e["wall_s"]["success"], 1, 1),
                      spread(e["wall_s"]["failure"], 1, 1)});
  doc.push_back(std::move(t));
  doc.push_back(Paragraph{
      "A step of progress is one at which a command's progress rose above its best so far, or a command "
      "completed. Time to success in steps is the simulator's first step with the goal holding."});
}

void films(const json& s, Document& doc) {
  if (s["films"].empty()) return;
  doc.push_back(Heading{2, "Filmstrips"});
  doc.push_back(Paragraph{"Episodes re-run from their evidence and rendered at the steps `dh film` picks: refusals, "
                          "recoveries, each command's start, motion and end, and the verdict."});
  for (const json& f : s["films"]) {
    doc.push_back(Paragraph{f["caption"].get<std::string>() +
                            (f["note"].get<std::string>().empty() ? "" : " (" + f["note"].get<std::string>() + ")")});
    if (!f["file"].get<std::string>().empty()) doc.push_back(Image{f["file"], f["caption"]});
  }
}

}  // namespace

Document build_document(const json& summary, const PlotResult& plots) {
  Document doc{Heading{1, summary["title"]}, Note{summary["benchmark_note"]}};
  overview(summary, doc);
  if (plots.skipped) doc.push_back(Paragraph{"Plots skipped: " + plots.note});
  success(summary, plots, doc);
  comparisons(summary, doc);
  attribution(summary, doc);
  per_task(summary, doc);
  positions(summary, plots, doc);
  wall_clock(summary, plots, doc);
  latency(summary, doc);
  mechanisms(summary, doc);
  execution(summary, plots, doc);
  films(summary, doc);
  policy(summary, doc);
  return doc;
}

}  // namespace dh::report
