#include <gtest/gtest.h>
#include <unistd.h>

#include "dh/common/stats.hpp"
#include "dh/report/climb.hpp"
#include "dh/report/report.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using dh::EpisodeRecord;
using nlohmann::json;
using namespace dh::report;

namespace {

// A folder of its own per test, removed at the end.
class TempDir {
 public:
  TempDir() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("dh_report_" + std::to_string(::getpid()) + "_" + test->test_suite_name() + "_" + test->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

EpisodeRecord row(const std::string& arm, const std::string& cell, unsigned task, unsigned seed, bool success,
                  double wall_s) {
  EpisodeRecord r;
  r.arm = arm;
  r.cell = cell;
  r.task = task;
  r.seed = seed;
  r.success = success;
  r.tick_limit = !success;
  r.outcome = success ? "success" : "budget_exhausted";
  r.wall_s = wall_s;
  r.budget = 300;
  r.steps = success ? 150 : 300;
  return r;
}

// Decisions of 2, 4 and 6 ms (one without latency_ns), plans answered after 150 and 250 ms, one plan never
// answered, an advice for an unknown request, and a torn last line.
void write_evidence(const fs::path& path) {
  std::ofstream out(path);
  const long long t0 = 1'700'000'000'000'000'000;
  out << json{{"kind", "episode_start"}, {"t_wall_ns", t0}, {"seq", 0}, {"component", "governor"}}.dump()
      << "\n";
  int seq = 1;
  for (long long ns : {2'000'000LL, 4'000'000LL, 6'000'000LL})
    out << json{{"kind", "decision"}, {"latency_ns", ns}, {"t_wall_ns", t0 + seq}, {"seq", seq++}}.dump()
        << "\n";
  out << json{{"kind", "decision"}, {"t_wall_ns", t0 + 9}, {"seq", seq++}}.dump() << "\n";
  const auto plan = [&](const std::string& kind, const std::string& id, long long t) {
    out << json{{"kind", kind}, {"request_id", id}, {"t_wall_ns", t}, {"seq", seq++}}.dump() << "\n";
  };
  plan("plan_request", "e/p0", t0 + 1'000'000'000);
  plan("advice", "e/p0", t0 + 1'150'000'000);
  plan("advice", "e/unknown", t0 + 1'160'000'000);
  plan("plan_request", "e/p1", t0 + 2'000'000'000);
  plan("advice", "e/p1", t0 + 2'250'000'000);
  plan("plan_request", "e/p2", t0 + 3'000'000'000);
  // Figure 3 in miniature: the push is refused, a pick and place substituted and completed.
  // Then the segment is handed to the policy until the episode ends.
  for (const json& r : {json{{"kind", "grounding"}, {"result", "grounded"}, {"command_id", "e/c0"}, {"capability", "push"}},
                        json{{"kind", "dispatch"}, {"command_id", "e/c0"}, {"step", 0}},
                        json{{"kind", "command_status"}, {"command_id", "e/c0"}, {"state", "refused"}},
                        json{{"kind", "decision"}, {"decision", "substitute"}, {"phase", "refused"}},
                        json{{"kind", "grounding"}, {"result", "grounded"}, {"command_id", "e/c1"}, {"capability", "pick_place"}},
                        json{{"kind", "dispatch"}, {"command_id", "e/c1"}, {"step", 2}},
                        json{{"kind", "decision"}, {"decision", "continue"}, {"command_id", "e/c1"}, {"step", 10}, {"progress", 0.5}},
                        json{{"kind", "decision"}, {"decision", "continue"}, {"command_id", "e/c1"}, {"step", 20}, {"progress", 0.5}},
                        json{{"kind", "command_status"}, {"command_id", "e/c1"}, {"state", "completed"}, {"step", 140}},
                        json{{"kind", "decision"}, {"decision", "request_replan"}, {"phase", "completed"}},
                        json{{"kind", "decision"}, {"decision", "request_replan"}, {"phase", "failed"}},
                        json{{"kind", "refusal"}, {"refusal", "budget"}},
                        json{{"kind", "grounding"}, {"result", "grounded"}, {"command_id", "e/c2"}, {"capability", "vla_act"}},
                        json{{"kind", "dispatch"}, {"command_id", "e/c2"}, {"step", 150}},
                        json{{"kind", "safety_hold"}, {"step", 151}, {"command_id", "e/c2"}},
                        json{{"kind", "safety_hold"}, {"step", 152}, {"command_id", "e/c2"}},
                        json{{"kind", "speed_limited"}, {"step", 160}, {"command_id", "e/c2"}},
                        json{{"kind", "episode_end"}, {"step", 200}}})
    out << r.dump() << "\n";
  out << R"({"kind":"decision","latency_ns":9)";  // torn: the writer died mid-record
}

// Two databases: "full" and "static" over cells goal (tasks 1, 2) and long (task 3), seeds 0 and 1.
// full: goal 3/4, long 1/2 (its seed-1 episode lost to infrastructure); static: goal 1/4, long 0/2.
// Paired: W = 3 (goal/1/0, goal/2/0, long/3/0), L = 0, ties = 3.
std::vector<Source> campaign(const fs::path& dir) {
  Source full{"full.db",
              {row("full", "goal", 1, 0, true, 10), row("full", "goal", 1, 1, true, 12),
               row("full", "goal", 2, 0, true, 11), row("full", "goal", 2, 1, false, 20),
               row("full", "long", 3, 0, true, 30), row("full", "long", 3, 1, false, 60)}};
  EpisodeRecord& lost = full.rows.back();
  lost.infrastructure = true;
  lost.tick_limit = false;
  lost.outcome = "infrastructure";
  full.rows[0].evidence_path = (dir / "full_goal_1_0.jsonl").string();
  write_evidence(full.rows[0].evidence_path);

  Source fixed{"static.db",
               {row("static", "goal", 1, 0, false, 15), row("static", "goal", 1, 1, true, 13),
                row("static", "goal", 2, 0, false, 16), row("static", "goal", 2, 1, false, 17),
                row("static", "long", 3, 0, false, 40), row("static", "long", 3, 1, false, 41)}};
  fixed.rows[0].evidence_path = (dir / "never_written.jsonl").string();
  return {full, fixed};
}

ReportOptions options(const fs::path& dir) {
  ReportOptions o;
  o.out_dir = dir / "report";
  o.title = "Test campaign";
  o.bootstrap_resamples = 2000;
  return o;
}

const json& find(const json& list, const std::string& arm, const std::string& cell) {
  for (const json& j : list)
    if (j["arm"] == arm && j["cell"] == cell) return j;
  throw std::runtime_error("no entry for " + arm + "/" + cell);
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool gnuplot_on_path() {
  std::stringstream dirs(std::getenv("PATH") ? std::getenv("PATH") : "");
  for (std::string d; std::getline(dirs, d, ':');)
    if (::access((fs::path(d) / "gnuplot").c_str(), X_OK) == 0) return true;
  return false;
}

}  // namespace

TEST(Summarize, SuccessPerArmAndCellCountsTheInfrastructureLossAsAFailure) {
  TempDir dir;
  const json s = summarize(campaign(dir.path()), options(dir.path()));
  EXPECT_EQ(s["rows"], 12);
  EXPECT_EQ(s["sources"].size(), 2u);
  EXPECT_EQ(s["sources"][1]["label"], "static.db");
  EXPECT_EQ(s["arms"], json({"full", "static"}));
  EXPECT_EQ(s["cells"], json({"goal", "long"}));
  EXPECT_EQ(s["infrastructure"], 1);
  EXPECT_EQ(s["duplicates"], 0);
  EXPECT_EQ(s["summary"].size(), 4u);

  const json& full_goal = find(s["summary"], "full", "goal");
  EXPECT_EQ(full_goal["successes"], 3);
  EXPECT_EQ(full_goal["episodes"], 4);
  EXPECT_DOUBLE_EQ(full_goal["rate"].get<double>(), 0.75);
  const dh::stats::Interval w = dh::stats::wilson(3, 4);
  EXPECT_DOUBLE_EQ(full_goal["wilson_lo"].get<double>(), w.lo);
  EXPECT_DOUBLE_EQ(full_goal["wilson_hi"].get<double>(), w.hi);
  EXPECT_EQ(full_goal["tick_limit"], 1);
  // Two cell/task clusters, goal/1 (2 of 2) and goal/2 (1 of 2): a resample is both of one (rate 1 or 0.5,
  // a quarter of the draws each) or one of each (0.75), so the percentiles are 0.5 and 1.
  EXPECT_EQ(full_goal["clusters"], 2);
  EXPECT_DOUBLE_EQ(full_goal["cluster_lo"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(full_goal["cluster_hi"].get<double>(), 1.0);

  const json& full_long = find(s["summary"], "full", "long");
  EXPECT_EQ(full_long["successes"], 1);
  EXPECT_EQ(full_long["episodes"], 2) << "the infrastructure loss stays in the denominator";
  EXPECT_DOUBLE_EQ(full_long["rate"].get<double>(), 0.5);
  EXPECT_EQ(full_long["infrastructure"], 1);

  EXPECT_EQ(find(s["summary"], "static", "goal")["successes"], 1);
  EXPECT_EQ(find(s["summary"], "static", "long")["successes"], 0);
  EXPECT_EQ(find(s["summary"], "static", "long")["tick_limit"], 2);
  EXPECT_EQ(s["arm_totals"][0]["arm"], "full");
  EXPECT_EQ(s["arm_totals"][0]["successes"], 4);
  EXPECT_EQ(s["arm_totals"][0]["episodes"], 6);
}

TEST(Summarize, PairedComparisonOverallAndPerCell) {
  TempDir dir;
  const json s = summarize(campaign(dir.path()), options(dir.path()));
  ASSERT_EQ(s["paired"].size(), 1u);
  const json& pair = s["paired"][0];
  EXPECT_EQ(pair["a"], "full");
  EXPECT_EQ(pair["b"], "static");
  const json& all = pair["overall"];
  EXPECT_EQ(all["n"], 6);
  EXPECT_EQ(all["wins"], 3);
  EXPECT_EQ(all["losses"], 0);
  EXPECT_EQ(all["ties"], 3);
  EXPECT_DOUBLE_EQ(all["diff_pp"].get<double>(), 50);
  EXPECT_DOUBLE_EQ(all["p"].get<double>(), 0.25);  // 2 · (1/2)³
  EXPECT_EQ(all["clusters"], 3);
  // d = (1, 0, 1, 0, 1, 0): variance 3/6 − 0.5² = 0.25.
  const double half = 100 * dh::stats::kZ95 * std::sqrt(0.25 / 6);
  EXPECT_NEAR(all["wald_lo_pp"].get<double>(), 50 - half, 1e-9);
  EXPECT_NEAR(all["wald_hi_pp"].get<double>(), 50 + half, 1e-9);
  EXPECT_LE(all["bootstrap_lo_pp"].get<double>(), 50);
  EXPECT_GE(all["bootstrap_hi_pp"].get<double>(), 50);
  EXPECT_EQ(s["bootstrap"]["resamples"], 2000);
  EXPECT_EQ(s["bootstrap"]["seed"], 20260926u);

  ASSERT_EQ(pair["cells"].size(), 2u);
  const json& goal = pair["cells"][0];
  EXPECT_EQ(goal["cell"], "goal");
  EXPECT_EQ(goal["n"], 4);
  EXPECT_EQ(goal["wins"], 2);
  EXPECT_EQ(goal["ties"], 2);
  EXPECT_DOUBLE_EQ(goal["p"].get<double>(), 0.5);
  const json& lng = pair["cells"][1];
  EXPECT_EQ(lng["cell"], "long");
  EXPECT_EQ(lng["wins"], 1);
  EXPECT_EQ(lng["ties"], 1) << "the infrastructure loss pairs as a failure";
  EXPECT_DOUBLE_EQ(lng["p"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(lng["bootstrap_lo_pp"].get<double>(), 50) << "one cluster: every resample is the same";
}

TEST(Summarize, TasksAndWallClock) {
  TempDir dir;
  const json s = summarize(campaign(dir.path()), options(dir.path()));
  ASSERT_EQ(s["tasks"].size(), 6u);
  EXPECT_EQ(s["tasks"][0],
            json({{"arm", "full"}, {"cell", "goal"}, {"task", 1}, {"successes", 2}, {"episodes", 2}}));
  EXPECT_EQ(s["tasks"][1]["successes"], 1);
  EXPECT_EQ(s["tasks"][4]["task"], 2);
  EXPECT_EQ(s["tasks"][4]["successes"], 0);

  const json& w = find(s["wall_clock"], "full", "goal");  // 10, 11, 12, 20
  EXPECT_EQ(w["episodes"], 4);
  EXPECT_DOUBLE_EQ(w["mean_s"].get<double>(), 13.25);
  EXPECT_DOUBLE_EQ(w["p50_s"].get<double>(), 11.5);
  EXPECT_DOUBLE_EQ(w["p90_s"].get<double>(), 17.6);
  EXPECT_DOUBLE_EQ(w["total_s"].get<double>(), 53);
}

TEST(Summarize, LatenciesFromEvidenceAndAMissingFileIsCounted) {
  TempDir dir;
  const json s = summarize(campaign(dir.path()), options(dir.path()));
  EXPECT_EQ(s["evidence"]["read"], 1);
  EXPECT_EQ(s["evidence"]["missing"], 1);
  EXPECT_EQ(s["evidence"]["not_recorded"], 10);
  EXPECT_EQ(s["evidence_missing"], 1);

  const json& d =
      s["latency"]["decision"];  // 2, 4, 6 ms; the torn line and the one without latency_ns skipped
  EXPECT_EQ(d["count"], 3);
  EXPECT_DOUBLE_EQ(d["p50_ms"].get<double>(), 4);
  EXPECT_DOUBLE_EQ(d["p90_ms"].get<double>(), 5.6);
  EXPECT_DOUBLE_EQ(d["p99_ms"].get<double>(), 5.96);
  const json& p = s["latency"]["planner"];  // 150, 250 ms
  EXPECT_EQ(p["count"], 2);
  EXPECT_DOUBLE_EQ(p["p50_ms"].get<double>(), 200);
  EXPECT_DOUBLE_EQ(p["p90_ms"].get<double>(), 240);
  EXPECT_DOUBLE_EQ(p["p99_ms"].get<double>(), 249);
  EXPECT_EQ(s["latency"]["unanswered_plan_requests"], 1);

  const json& by_arm = s["latency"]["by_arm"];
  ASSERT_EQ(by_arm.size(), 2u);
  EXPECT_EQ(by_arm[0]["decision"]["count"], 3);
  EXPECT_EQ(by_arm[1]["arm"], "static");
  EXPECT_EQ(by_arm[1]["planner"]["count"], 0);
  EXPECT_TRUE(by_arm[1]["planner"]["p50_ms"].is_null());
}

TEST(Summarize, MechanismsFromEvidence) {
  TempDir dir;
  const json s = summarize(campaign(dir.path()), options(dir.path()));
  ASSERT_EQ(s["mechanisms"].size(), 2u);
  const json& m = s["mechanisms"][0];
  EXPECT_EQ(m["arm"], "full");
  EXPECT_EQ(m["episodes"], 1) << "one evidence file read";
  EXPECT_EQ(m["decisions"]["substitute"], 1);
  EXPECT_EQ(m["decisions"]["next_step"], 1) << "a replan request after a completion is the next step";
  EXPECT_EQ(m["decisions"]["request_replan"], 1);
  EXPECT_EQ(m["refusals"], 2) << "the capability's refusal and the grounding refusal";
  EXPECT_EQ(m["commands"], json::parse(R"([{"capability":"pick_place","completed":1,"dispatched":1,"steps":148},
                                           {"capability":"push","completed":0,"dispatched":1,"steps":2},
                                           {"capability":"vla_act","completed":0,"dispatched":1,"steps":50}])"));
  EXPECT_EQ(m["steps"], 200);
  EXPECT_DOUBLE_EQ(m["policy_step_share"].get<double>(), 0.25);
  EXPECT_EQ(m["safety_holds"], 2);
  EXPECT_EQ(m["episodes_with_hold"], 1);
  EXPECT_DOUBLE_EQ(m["holds_per_episode"].get<double>(), 2.0);
  EXPECT_EQ(m["speed_limited"], 1);
  EXPECT_DOUBLE_EQ(m["speed_limited_share"].get<double>(), 1.0 / 200);
  EXPECT_EQ(s["mechanisms"][1]["episodes"], 0);
  EXPECT_TRUE(s["mechanisms"][1]["holds_per_episode"].is_null());
  EXPECT_TRUE(s["mechanisms"][1]["policy_step_share"].is_null());
}

// The paper's execution figures: the outcome composition, the budget used by outcome, steps after the last
// progress, episodes never under the policy, time to success, and the wall clock by outcome.
TEST(Summarize, ExecutionFiguresFromRowsAndEvidence) {
  TempDir dir;
  auto sources = campaign(dir.path());
  for (auto& source : sources)
    for (auto& r : source.rows)
      if (r.success) r.sim_goal_step = 140;
  // full goal/1/0 is a failure here, so its evidence's end counts: progress rose at step 10 and the pick
  // and place completed at 140, the episode ended at 200 under vla_act.
  EpisodeRecord& gave_up = sources[0].rows[0];
  gave_up.success = false;
  gave_up.outcome = "gave_up";
  gave_up.steps = 200;
  gave_up.sim_goal_step = -1;  // set above while it was a success
  const json s = summarize(sources, options(dir.path()));
  ASSERT_EQ(s["execution"].size(), 2u);
  const json& full = s["execution"][0];
  EXPECT_EQ(full["arm"], "full");
  EXPECT_EQ(full["outcomes"], json::parse(R"({"success":3,"gave_up":1,"budget_exhausted":1,"infrastructure":1})"));
  EXPECT_EQ(full["budget_used"]["success"]["count"], 3u);
  EXPECT_DOUBLE_EQ(full["budget_used"]["success"]["p50"].get<double>(), 0.5);
  EXPECT_EQ(full["budget_used"]["failure"]["count"], 2u) << "the loss to infrastructure used no budget of its own";
  EXPECT_NEAR(full["budget_used"]["failure"]["mean"].get<double>(), (200.0 / 300 + 1.0) / 2, 1e-12);
  EXPECT_EQ(full["steps_after_progress"]["count"], 1u);
  EXPECT_DOUBLE_EQ(full["steps_after_progress"]["p50"].get<double>(), 60.0);
  EXPECT_EQ(full["traced"], 1u);
  EXPECT_EQ(full["zero_policy_steps"], 0u) << "50 steps were under vla_act";
  EXPECT_EQ(full["time_to_success"]["steps"]["count"], 3u);
  EXPECT_DOUBLE_EQ(full["time_to_success"]["steps"]["p50"].get<double>(), 140.0);
  EXPECT_DOUBLE_EQ(full["wall_s"]["success"]["p50"].get<double>(), 12.0);  // 11, 12, 30
  EXPECT_EQ(full["wall_s"]["failure"]["count"], 2u) << "the loss to infrastructure is not a failure's wall clock";
  const json& fixed = s["execution"][1];
  EXPECT_EQ(fixed["traced"], 0u) << "its one evidence file was never written";
  EXPECT_TRUE(fixed["steps_after_progress"]["p50"].is_null());
  const std::string md = read(render(sources, options(dir.path())).markdown);
  EXPECT_NE(md.find("| full | 3 | 1 | 1 | 1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| full | 50 [50, 50] (3) | "), std::string::npos) << md;
  EXPECT_NE(md.find(" | 60 [60, 60] (1) | 0 of 1 |"), std::string::npos) << md;
}

TEST(Summarize, ARepeatedKeyIsCountedAsADuplicateAndNowhereElse) {
  TempDir dir;
  std::vector<Source> sources = campaign(dir.path());
  sources.push_back({"rerun.db", {row("static", "goal", 1, 0, true, 14)}});  // static's goal/1/0 again
  const json s = summarize(sources, options(dir.path()));
  EXPECT_EQ(s["duplicates"], 1);
  EXPECT_EQ(find(s["summary"], "static", "goal")["episodes"], 4) << "the repeat is not a fifth episode";
  EXPECT_EQ(find(s["summary"], "static", "goal")["successes"], 1);
  EXPECT_EQ(s["paired"][0]["overall"]["n"], 6);
  EXPECT_EQ(s["paired"][0]["overall"]["wins"], 3);
}

TEST(Summarize, EpisodesWhereTheSimulatorsVerdictDiffersFromTheGovernorsAreFlaggedAndRendered) {
  TempDir dir;
  EpisodeRecord agrees = row("full", "goal", 1, 0, true, 10), differs = row("full", "goal", 1, 1, true, 10),
                unknown = row("full", "goal", 1, 2, false, 10);
  agrees.sim_success = true;
  agrees.sim_goal_step = 120;
  differs.sim_success = false;  // the governor says success, the simulator never saw the goal hold
  differs.episode_id = "ep-differs";
  const std::vector<Source> sources{{"c.db", {agrees, differs, unknown}}};
  const json s = summarize(sources, options(dir.path()));
  EXPECT_EQ(s["verdict"]["reported"], 2);
  ASSERT_EQ(s["verdict"]["disagreements"].size(), 1u);
  EXPECT_EQ(s["verdict"]["disagreements"][0]["seed"], 1);
  EXPECT_EQ(s["verdict"]["disagreements"][0]["governor"], true);
  EXPECT_EQ(s["verdict"]["disagreements"][0]["simulator"], false);
  const std::string md = read(render(sources, options(dir.path())).markdown);
  EXPECT_NE(md.find("reported for 2 of 3 episodes; it disagrees with the governor's on 1."), std::string::npos) << md;
  EXPECT_NE(md.find("| full | goal | 1 | 1 | success | failure | – | ep-differs |"), std::string::npos) << md;
}

// An arm that ran without a capability it needs says so per arm, in the JSON and under the success table;
// rows that do not say (older databases) are counted apart.
TEST(Summarize, AnArmThatRanWithoutACapabilitySaysSo) {
  TempDir dir;
  EpisodeRecord a = row("full", "goal", 1, 0, true, 10), b = row("full", "goal", 1, 1, false, 10),
                c = row("full", "goal", 1, 2, true, 10), d = row("static", "goal", 1, 0, true, 10);
  a.capabilities_missing = b.capabilities_missing = std::vector<std::string>{"vla_act"};
  d.capabilities_missing = std::vector<std::string>{};
  const std::vector<Source> sources{{"c.db", {a, b, c, d}}};
  const json s = summarize(sources, options(dir.path()));
  const json& full = s["arm_totals"][0];
  ASSERT_EQ(full["arm"], "full");
  EXPECT_EQ(full["ran_without"], json({{"vla_act", 2}}));
  EXPECT_EQ(full["capabilities_unknown"], 1);
  EXPECT_TRUE(s["arm_totals"][1]["ran_without"].empty());
  EXPECT_EQ(s["arm_totals"][1]["capabilities_unknown"], 0);
  const std::string md = read(render(sources, options(dir.path())).markdown);
  EXPECT_NE(md.find("Warning: full ran without vla_act in 2 of its 3 episodes"), std::string::npos) << md;
  EXPECT_NE(md.find("For 1 of full's 3 episodes the database does not say"), std::string::npos) << md;
  EXPECT_EQ(md.find("static ran without"), std::string::npos) << md;
}

// Each disagreement is put down to its cause from the terms judged at the end: the goal lost by then,
// the rests bands disagreeing with the simulator's contacts, or perception's view; older evidence that
// does not judge the terms says unknown.
TEST(Summarize, ADisagreementWithTheOracleIsPutDownToItsCause) {
  TempDir dir;
  const auto episode = [&](unsigned seed, bool oracle_at_end, std::optional<bool> on_true_poses, bool perceived = false) {
    EpisodeRecord r = row("full-perception", "goal", 1, seed, perceived, 10);
    r.sim_success = !perceived;  // every episode here is a disagreement
    r.sim_goal_step = perceived ? -1 : 100;
    r.sim_goal_at_end = oracle_at_end;
    r.evidence_path = (dir.path() / ("c" + std::to_string(seed) + ".jsonl")).string();
    std::ofstream out(r.evidence_path);
    out << json{{"kind", "episode_start"}, {"verifier", "perception"}, {"goal", {"On(bowl, plate)", "On(cup, plate)"}}}.dump() << "\n";
    if (perceived) out << json{{"kind", "perceived_verdict"}, {"step", 130}, {"value", true}}.dump() << "\n";
    json end = {{"kind", "perceived_verdict_end"}, {"step", 140}, {"value", perceived}, {"oracle", oracle_at_end}};
    if (on_true_poses)
      end["terms"] = {{{"term", "On(bowl, plate)"}, {"perceived", false}, {"on_true_poses", true}},
                      {{"term", "On(cup, plate)"}, {"perceived", true}, {"on_true_poses", *on_true_poses}}};
    out << end.dump() << "\n";
    return r;
  };
  EpisodeRecord under_oracle = episode(7, true, false);  // ended on the oracle: not compared
  {
    std::ofstream out(under_oracle.evidence_path);
    out << json{{"kind", "episode_start"}, {"verifier", "oracle"}, {"goal", {"On(bowl, plate)"}}}.dump() << "\n"
        << json{{"kind", "perceived_verdict_end"}, {"step", 140}, {"value", false}, {"oracle", true}}.dump() << "\n";
  }
  const std::vector<Source> sources{{"c.db", {episode(0, false, true), episode(1, true, false), episode(2, true, true),
                                              episode(3, true, true), episode(4, true, std::nullopt),
                                              episode(5, false, true, true), episode(6, false, false, true),
                                              under_oracle}}};
  const json s = summarize(sources, options(dir.path()));
  json all;
  for (const json& p : s["verdict"]["by_arm"][0]["predicates"])
    if (p["predicate"] == "all") all = p;
  ASSERT_TRUE(all.is_object());
  EXPECT_EQ(all["false_failure"]["k"], 5);
  EXPECT_EQ(all["false_failure_causes"], (json{{"band", 1}, {"lost", 1}, {"perception", 2}, {"unknown", 1}}));
  // A false success: the bands accept the simulator's own poses (band) or do not (perception).
  EXPECT_EQ(all["false_success"]["k"], 2);
  EXPECT_EQ(all["false_success_causes"], (json{{"band", 1}, {"perception", 1}}));
  const std::string md = read(render(sources, options(dir.path())).markdown);
  EXPECT_NE(md.find("| band 1, lost 1, perception 2, unknown 1 |"), std::string::npos) << md;
}

// Four episodes of an arm that ends on the verdict from perception: one where both verdicts agree on
// success, one false success (perceived, the goal never held), one false failure (the goal held, never
// perceived) and one where both say failure; plus one without a perceived verdict, counted nowhere.
TEST(Summarize, TheVerdictFromPerceptionIsComparedWithTheSimulatorsPerPredicate) {
  TempDir dir;
  const auto episode = [&](unsigned seed, bool oracle, std::optional<bool> perceived, const std::string& goal) {
    EpisodeRecord r = row("full-perception", "goal", 1, seed, perceived.value_or(false), 10);
    r.sim_success = oracle;
    r.sim_goal_step = oracle ? 100 : -1;
    r.sim_goal_at_end = oracle;
    r.evidence_path = (dir.path() / ("e" + std::to_string(seed) + ".jsonl")).string();
    std::ofstream out(r.evidence_path);
    // Episode 0 ran on the UR7e (`--robot ur7e`); the others on the scenes' own arm, which is not recorded.
    if (seed == 0) out << json{{"kind", "episode_request"}, {"robot", "ur7e"}}.dump() << "\n";
    out << json{{"kind", "episode_start"}, {"verifier", "perception"}, {"goal", json::array({goal})}}.dump() << "\n";
    if (perceived) {
      if (*perceived) out << json{{"kind", "perceived_verdict"}, {"step", 130}, {"value", true}}.dump() << "\n";
      out << json{{"kind", "perceived_verdict_end"}, {"step", 140}, {"value", *perceived}, {"oracle", oracle}}.dump() << "\n";
    }
    return r;
  };
  const std::vector<Source> sources{{"p.db",
                                     {episode(0, true, true, "On(bowl, plate)"), episode(1, false, true, "On(bowl, plate)"),
                                      episode(2, true, false, "In(bowl, cabinet_top_region)"),
                                      episode(3, false, false, "In(bowl, cabinet_top_region)"),
                                      episode(4, true, std::nullopt, "On(bowl, plate)")}}};
  const json s = summarize(sources, options(dir.path()));
  const json& arm = s["verdict"]["by_arm"][0];
  EXPECT_EQ(arm["verifiers"], json::array({"perception"}));
  EXPECT_EQ(arm["robots"], json::array({"panda", "ur7e"}));
  std::map<std::string, json> by;
  for (const json& p : arm["predicates"]) by[p["predicate"]] = p;
  ASSERT_EQ(by.size(), 3u) << arm.dump();
  EXPECT_EQ(by["all"]["episodes"], 4);
  EXPECT_EQ(by["all"]["false_success"]["k"], 1);
  EXPECT_EQ(by["all"]["false_success"]["n"], 2);
  EXPECT_EQ(by["all"]["false_failure"]["k"], 1);
  EXPECT_EQ(by["all"]["false_failure"]["n"], 2);
  EXPECT_EQ(by["On"]["false_success"]["k"], 1);
  EXPECT_EQ(by["On"]["false_failure"]["n"], 1);
  EXPECT_EQ(by["In"]["false_failure"]["k"], 1);
  EXPECT_EQ(by["In"]["false_success"]["k"], 0);
  const std::string md = read(render(sources, options(dir.path())).markdown);
  EXPECT_NE(md.find("ended on (oracle: the simulator's; perception: the goal judged on perceived frames): "
                    "full-perception: perception. The robot they ran on: full-perception: panda and ur7e."),
            std::string::npos) << md;
  EXPECT_NE(md.find("| full-perception | all | 4 | 2 | 2 | 50.0 (1/2) |"), std::string::npos) << md;
  // Rows whose evidence was not kept say nothing of their verifier.
  EpisodeRecord unread = row("full", "goal", 1, 0, true, 10);
  unread.evidence_path = (dir.path() / "not_kept.jsonl").string();
  const std::string without = read(render({{"q.db", {unread}}}, options(dir.path())).markdown);
  EXPECT_NE(without.find("full: unknown (no evidence read)."), std::string::npos) << without;
}

TEST(Summarize, FailuresByLayerPerArmAndCellWithTheHarnessShare) {
  TempDir dir;
  auto sources = campaign(dir.path());
  ReportOptions o = options(dir.path());
  json s = summarize(sources, o);
  EXPECT_TRUE(s["attribution"]["cells"].empty()) << "no labels stored";
  EXPECT_TRUE(s["attribution"]["config"].is_null());
  // full: goal/2/1 failed (execution), long/3/1 was lost (infrastructure, not the harness's).
  sources[0].attributed = {{"full", "goal", 2, 1, 7, "capability_execution", true},
                           {"full", "long", 3, 1, 0, "infrastructure", false}};
  sources[1].attributed = {{"static", "goal", 1, 0, 8, "verification", true},
                           {"static", "goal", 2, 0, 7, "capability_execution", true}};
  o.attribution_config = "attr-test";
  s = summarize(sources, o);
  EXPECT_EQ(s["attribution"]["config"], "attr-test");
  const json& full_goal = find(s["attribution"]["cells"], "full", "goal");
  EXPECT_EQ(full_goal["failed"], 1);
  EXPECT_EQ(full_goal["attributed"], 1);
  EXPECT_EQ(full_goal["u_d"], 1);
  const json& full_long = find(s["attribution"]["cells"], "full", "long");
  EXPECT_EQ(full_long["u_d"], 0) << "infrastructure is not the harness's";
  const json& static_goal = find(s["attribution"]["cells"], "static", "goal");
  EXPECT_EQ(static_goal["failed"], 3);
  EXPECT_EQ(static_goal["attributed"], 2) << "one failure not labelled yet";
  ASSERT_EQ(static_goal["layers"].size(), 2u);
  EXPECT_EQ(static_goal["layers"][0]["name"], "capability_execution") << "upstream first";
  EXPECT_EQ(static_goal["layers"][1]["name"], "verification");
  const auto files = render(sources, o);
  std::ifstream md(files.markdown);
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("| static | goal | 3 | 2 | capability_execution 1, verification 1 | 2 |"), std::string::npos)
      << text;
}

TEST(Summarize, NoRowsIsAnEmptyReport) {
  const json s = summarize({}, ReportOptions{});
  EXPECT_EQ(s["rows"], 0);
  EXPECT_TRUE(s["summary"].empty());
  EXPECT_TRUE(s["paired"].empty());
  EXPECT_EQ(s["latency"]["decision"]["count"], 0);
  EXPECT_NE(s["benchmark_note"].get<std::string>().find("NOT LIBERO"), std::string::npos);
}

TEST(Render, WritesMarkdownHtmlJsonAndPlotsWhenGnuplotIsThere) {
  TempDir dir;
  const ReportOptions o = options(dir.path());
  const ReportFiles files = render(campaign(dir.path()), o);
  ASSERT_TRUE(fs::exists(files.markdown));
  ASSERT_TRUE(fs::exists(files.html));
  ASSERT_TRUE(fs::exists(files.json));
  EXPECT_EQ(json::parse(read(files.json))["rows"], 12);

  for (const fs::path& f : {files.markdown, files.html}) {
    const std::string text = read(f);
    EXPECT_NE(text.find("Test campaign"), std::string::npos) << f;
    EXPECT_NE(text.find("NOT LIBERO or LIBERO-Pro"), std::string::npos) << f;
    EXPECT_NE(text.find("75.0 %"), std::string::npos) << f;  // full/goal
    EXPECT_NE(text.find("+50.0"), std::string::npos) << f;   // Δ pp
    EXPECT_NE(text.find("0.25"), std::string::npos) << f;    // p
    EXPECT_NE(text.find("2000 resamples"), std::string::npos) << f;
    EXPECT_NE(text.find("lost to infrastructure: 1"), std::string::npos) << f;
    EXPECT_NE(text.find("missing or unreadable: 1"), std::string::npos) << f;
    EXPECT_NE(text.find("200.0"), std::string::npos) << f;  // planner p50 ms
  }
  EXPECT_NE(read(files.markdown).find("| full | goal | 3 | 4 | 75.0 % |"), std::string::npos);

  const bool gnuplot = gnuplot_on_path();
  EXPECT_EQ(files.plots_skipped, !gnuplot) << files.plots_note;
  EXPECT_EQ(fs::exists(o.out_dir / "success.png"), gnuplot);
  EXPECT_EQ(fs::exists(o.out_dir / "wall_clock.png"), gnuplot);
  EXPECT_EQ(fs::exists(o.out_dir / "budget.png"), gnuplot);
  EXPECT_EQ(files.plots.size(), gnuplot ? 3u : 0u);
  EXPECT_EQ(read(files.html).find("<img src=\"success.png\"") != std::string::npos, gnuplot);
}

// A -pos cell: its episodes tallied by the magnitude each seed picked (seed mod 2 here), with the
// displacement radius, a table and a plot; other cells stay out of it.
TEST(Render, PosCellsAreTalliedByTheSeedsMagnitudeAndPlotted) {
  TempDir dir;
  ReportOptions o = options(dir.path());
  o.positions["goal-pos"] = dh::PosSpec{{0.1, 0.5}, 0.4};
  Source s{"pos", {}};
  for (unsigned seed = 21; seed <= 28; ++seed) {
    s.rows.push_back(row("full", "goal-pos", seed % 3, seed, seed % 2 == 0 || seed == 21, 10));  // x0.1: 4/4, x0.5: 1/4
    s.rows.push_back(row("full", "goal", 0, seed, true, 10));
  }
  const json sum = summarize({s}, o);
  ASSERT_EQ(sum["positions"].size(), 2u);
  EXPECT_EQ(sum["positions"][0]["magnitude"], 0.1);
  EXPECT_NEAR(sum["positions"][0]["radius_m"].get<double>(), 0.04, 1e-12);
  EXPECT_EQ(sum["positions"][0]["successes"], 4u);
  EXPECT_EQ(sum["positions"][1]["magnitude"], 0.5);
  EXPECT_EQ(sum["positions"][1]["successes"], 1u);
  EXPECT_EQ(sum["positions"][1]["episodes"], 4u);
  const ReportFiles files = render({s}, o);
  EXPECT_NE(read(files.markdown).find("| full | goal-pos | x0.5 | 0.20 | 1 | 4 | 25.0 % |"), std::string::npos)
      << read(files.markdown);
  const bool gnuplot = gnuplot_on_path();
  EXPECT_EQ(fs::exists(o.out_dir / "positions.png"), gnuplot) << files.plots_note;
  EXPECT_EQ(files.plots.size(), gnuplot ? 4u : 0u);
  // Without -pos rows there is no such table or plot, and an old plot of it is removed.
  const ReportFiles plain = render(campaign(dir.path()), o);
  EXPECT_EQ(read(plain.markdown).find("Success against displacement"), std::string::npos);
  EXPECT_FALSE(fs::exists(o.out_dir / "positions.png"));
}

TEST(Render, FilmstripsAreShownWithTheirCaptionsAndAMissingOneSaysWhy) {
  TempDir dir;
  ReportOptions o = options(dir.path());
  o.films = {{"films/full_goal-swap_5_21.png", "Figure 3's case: full arm, goal-swap task 5 seed 21 (success)", ""},
             {"", "a door episode: full arm, long task 5 seed 21 (gave_up)", "no filmstrip: ep.jsonl: no such file"}};
  const std::string md = read(render(campaign(dir.path()), o).markdown);
  EXPECT_NE(md.find("## Filmstrips"), std::string::npos);
  EXPECT_NE(md.find("](films/full_goal-swap_5_21.png)"), std::string::npos) << md;
  EXPECT_NE(md.find("a door episode: full arm, long task 5 seed 21 (gave_up) (no filmstrip: ep.jsonl: no such file)"),
            std::string::npos)
      << md;
  EXPECT_EQ(read(render(campaign(dir.path()), options(dir.path())).markdown).find("## Filmstrips"), std::string::npos)
      << "no films, no section";
}

TEST(Render, WithoutGnuplotTheReportStillRendersAndSaysSo) {
  TempDir dir;
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", dir.path().c_str(), 1);  // a PATH with no gnuplot on it
  const ReportFiles files = render(campaign(dir.path()), options(dir.path()));
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_TRUE(files.plots_skipped);
  EXPECT_TRUE(files.plots.empty());
  EXPECT_NE(files.plots_note.find("gnuplot"), std::string::npos);
  for (const fs::path& f : {files.markdown, files.html}) {
    EXPECT_NE(read(f).find("Plots skipped: gnuplot was not found"), std::string::npos) << f;
    EXPECT_EQ(read(f).find(".png"), std::string::npos) << f;
  }
}

TEST(Render, TinyPValuesAreWrittenInScientificNotation) {
  TempDir dir;
  Source s{"paper.db", {}};
  for (unsigned seed = 0; seed < 97; ++seed) {  // W = 89, L = 8 → p = 2.00e-18
    s.rows.push_back(row("a", "goal", 1, seed, seed < 89, 1));
    s.rows.push_back(row("b", "goal", 1, seed, seed >= 89, 1));
  }
  ReportOptions o = options(dir.path());
  o.plots = false;
  const ReportFiles files = render({s}, o);
  EXPECT_NE(read(files.markdown).find("| 2.00e-18 |"), std::string::npos);
  EXPECT_NE(read(files.markdown).find("Plots skipped: not requested."), std::string::npos);
}

TEST(Summarize, ThePolicySectionReadsTheTrainingRecordAndNamesAMissingOne) {
  TempDir dir;
  ReportOptions o = options(dir.path());
  o.policy_dir = dir.path() / "policy";
  json s = summarize(campaign(dir.path()), o);
  EXPECT_NE(s["policy"]["error"].get<std::string>().find("dh train-policy"), std::string::npos);
  fs::create_directories(o.policy_dir);
  std::ofstream(o.policy_dir / "train.json")
      << R"({"weights":"vla_mlp.dhp","version":"mlp-abc","sha256":"abc","loss_curve":"loss.csv",
             "training":{"epochs":2,"seed":1},"train_seconds":3.5})";
  std::ofstream(o.policy_dir / "loss.csv") << "epoch,train_mse,validation_mse\n1,0.5,0.6\n2,0.25,0.3\n";
  s = summarize(campaign(dir.path()), o);
  EXPECT_EQ(s["policy"]["version"], "mlp-abc");
  ASSERT_EQ(s["policy"]["curve"].size(), 2u);
  EXPECT_DOUBLE_EQ(s["policy"]["curve"][1]["validation"].get<double>(), 0.3);
  o.policy_dir.clear();
  EXPECT_TRUE(summarize(campaign(dir.path()), o)["policy"].is_null());
}

// The climb's plot: each point with its interval and decision in climb.dat, climb.png drawn when gnuplot
// is there (the reason otherwise), and nothing to draw said so.
TEST(Climb, EachRoundsSuccessWithItsIntervalAndDecisionIsDrawn) {
  TempDir dir;
  const std::vector<ClimbPoint> points{{"round 1", 0.5, 0.4, 0.6, "rejected"},
                                       {"round 2", 0.5, 0.4, 0.6, "admitted"},
                                       {"final", 0.625, 0.5, 0.75, ""}};
  const std::string why_not = draw_climb(points, dir.path());
  std::ifstream dat(dir.path() / "climb.dat");
  const std::string data((std::istreambuf_iterator<char>(dat)), std::istreambuf_iterator<char>());
  if (!gnuplot_on_path()) {
    EXPECT_NE(why_not.find("gnuplot was not found"), std::string::npos) << why_not;
    return;
  }
  EXPECT_EQ(why_not, "");
  EXPECT_GT(fs::file_size(dir.path() / "climb.png"), 0u);
  EXPECT_NE(data.find("1 \"round 2\" 50 40 60 \"admitted\""), std::string::npos) << data;
  EXPECT_NE(data.find("2 \"final\" 62.5 50 75 \"-\""), std::string::npos) << data;
  EXPECT_EQ(draw_climb({}, dir.path()), "no round has a success yet");
  EXPECT_FALSE(fs::exists(dir.path() / "climb.png")) << "an earlier climb's image stayed";
}
