// A campaign over two simulator worker processes: killed half way, resumed without rerunning or
// double-counting a finished episode, then reported; and one of its workers SIGKILLed mid-campaign.
#include <signal.h>
#include <sys/wait.h>

#include <nlohmann/json.hpp>
#include <algorithm>
#include <fstream>
#include <set>

#include "campaign_helpers.hpp"
#include "harness.hpp"

using namespace dh;
using namespace std::chrono_literals;

namespace {

constexpr const char* kPlan = " campaign --arms full --cells goal,goal-task --seeds 1-3 --ready-timeout-ms 20000";
constexpr std::size_t kEpisodes = 2 * 10 * 3;

}  // namespace

TEST(Campaign, KilledHalfWayResumesWithoutRerunningAndReports) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto db = env.runs / "c.db";
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");

  // First run: killed (SIGKILL, no chance to clean up) once a fifth of the episodes are recorded.
  const pid_t first = itest::spawn_shell("exec " + dh + kPlan + " --db " + db.string() + " > " +
                                  (env.runs / "first.log").string() + " 2>&1");
  ASSERT_GT(first, 0);
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (itest::rows_in(db) < kEpisodes / 5 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(50ms);
  kill(first, SIGKILL);
  waitpid(first, nullptr, 0);
  const std::size_t recorded = itest::rows_in(db);
  ASSERT_GE(recorded, kEpisodes / 5) << "the first run recorded too little before the deadline";
  ASSERT_LT(recorded, kEpisodes) << "the first run finished before it could be killed";

  // Second run: resumes; channels still busy with the killed run's episodes are waited for.
  auto [out, status] = itest::run_command(dh + kPlan + " --db " + db.string() + " --json 2>&1");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j["campaign"]["recorded_before"].get<std::size_t>(), recorded);
  EXPECT_EQ(j["campaign"]["ran_now"].get<std::size_t>(), kEpisodes - recorded);
  EXPECT_EQ(j["campaign"]["remaining"].get<std::size_t>(), 0u);
  std::size_t episodes = 0;
  for (const auto& row : j["summary"]) {
    EXPECT_EQ(row["episodes"].get<std::size_t>(), kEpisodes / 2) << row.dump();
    episodes += row["episodes"].get<std::size_t>();
  }
  EXPECT_EQ(episodes, kEpisodes);

  const auto rows = campaign::CampaignDb::read_rows(db);
  ASSERT_EQ(rows.size(), kEpisodes);
  std::set<std::string> workers, keys;
  std::size_t with_physics = 0, with_verdict = 0;
  for (const auto& r : rows) {
    workers.insert(r.worker);
    keys.insert(campaign::to_string(campaign::key_of(r)));
    EXPECT_FALSE(r.infrastructure) << r.episode_id << ": " << r.reason;
    with_physics += r.physics_s > 0;
    with_verdict += r.sim_success.has_value();
    // With the latch on, the governor ends on the simulator's verdict: the two never disagree.
    EXPECT_FALSE(r.verdict_disagrees()) << r.episode_id << ": governor " << r.success << ", simulator "
                                        << r.sim_success.value_or(false) << " (goal first held at step "
                                        << r.sim_goal_step << ")";
    // The governor ends at the decision after the goal first held (decisions come every 10 steps).
    if (r.success && r.sim_success) {
      EXPECT_LE(r.sim_goal_step, static_cast<int>(r.steps)) << r.episode_id;
    }
    EXPECT_TRUE(r.capabilities_missing)
        << r.episode_id << ": the governor's result says what the arm ran without";
    if (r.cell == "goal" && r.task == 8) {
      EXPECT_TRUE(r.success) << r.episode_id << ": " << r.reason;
    }
  }
  EXPECT_EQ(keys.size(), kEpisodes) << "one row per (arm, cell, task, seed)";
  EXPECT_EQ(workers, (std::set<std::string>{"local_a", "local_b"})) << "episodes ran on both worker processes";
  EXPECT_GE(with_physics, kEpisodes * 9 / 10) << "the simulator's physics time reached the rows";
  EXPECT_EQ(with_verdict, with_physics) << "the simulator's verdict comes with its physics report";

  // A third run has nothing left; another plan on the same database is refused.
  std::tie(out, status) = itest::run_command(dh + kPlan + " --db " + db.string() + " --json");
  ASSERT_EQ(status, 0) << out;
  EXPECT_EQ(nlohmann::json::parse(out)["campaign"]["ran_now"].get<int>(), 0);
  std::tie(out, status) = itest::run_command(dh + " campaign --cells goal --seeds 1-6 --db " + db.string() + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("holds another campaign"), std::string::npos) << out;

  // The report renders.
  const auto report_dir = env.runs / "report";
  std::tie(out, status) = itest::run_command(dh + " report --db " + db.string() + " --out " + report_dir.string());
  ASSERT_EQ(status, 0) << out;
  std::ifstream md(report_dir / "report.md");
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("NOT LIBERO"), std::string::npos);
  EXPECT_NE(text.find("| full | goal | "), std::string::npos) << text.substr(0, 2000);
  EXPECT_TRUE(std::filesystem::exists(report_dir / "report.html"));
  // A chosen episode's filmstrip in the report, re-run from its evidence; an episode it lacks is named.
  std::tie(out, status) = itest::run_command(dh + " report --db " + db.string() + " --out " + report_dir.string() +
                                             " --films full/goal/8/1 2>&1");
  ASSERT_EQ(status, 0) << out;
  EXPECT_TRUE(std::filesystem::exists(report_dir / "films" / "full_goal_8_1.png"));
  std::ifstream md2(report_dir / "report.md");
  const std::string with_film((std::istreambuf_iterator<char>(md2)), std::istreambuf_iterator<char>());
  EXPECT_NE(with_film.find("](films/full_goal_8_1.png)"), std::string::npos) << with_film.substr(with_film.find("## Filmstrips"));
  std::tie(out, status) = itest::run_command(dh + " report --db " + db.string() + " --out " + report_dir.string() +
                                             " --films full/goal/8/99 2>&1");
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("--films full/goal/8/99: no such episode"), std::string::npos) << out;

  // Every failed episode gets an attribution layer from its evidence, and the labels are stored.
  const auto experience = env.runs / "experience.jsonl";
  std::tie(out, status) =
      itest::run_command(dh + " attribute --db " + db.string() + " --json --export " + experience.string());
  const std::size_t failed = std::count_if(rows.begin(), rows.end(), [](const EpisodeRecord& r) { return !r.success; });
  ASSERT_EQ(status, 0) << "an episode matched no layer, or its evidence was unreadable: " << out;
  const auto attribution = nlohmann::json::parse(out);
  EXPECT_EQ(attribution["failed"].get<std::size_t>(), failed);
  EXPECT_EQ(attribution["unmatched"].get<std::size_t>(), 0u);
  std::size_t labelled = 0;
  for (const auto& layer : attribution["layers"]) labelled += layer["count"].get<std::size_t>();
  EXPECT_EQ(labelled, failed);
  EXPECT_EQ(campaign::CampaignDb::open(db).attributions(attribution["config"]).size(), failed);
  std::ifstream lines(experience);
  std::size_t exported = 0;
  for (std::string line; std::getline(lines, line); ++exported)
    EXPECT_TRUE(nlohmann::json::parse(line).contains("signature")) << line;
  EXPECT_EQ(exported, failed);
}

TEST(Campaign, BadPlansAreRefusedBeforeAnythingRuns) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto db = (env.runs / "x.db").string();
  auto [out, status] = itest::run_command(dh + " campaign --arms full,wizard --cells goal --seeds 1 --db " + db + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("unknown arm 'wizard'"), std::string::npos) << out;
  std::tie(out, status) = itest::run_command(dh + " campaign --cells goal-spatial --seeds 1 --db " + db + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("unknown suite 'goal-spatial'"), std::string::npos) << out;
  std::tie(out, status) = itest::run_command(dh + " campaign --cells goal --seeds 5-3 --db " + db + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--seeds"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(db) && itest::rows_in(db) > 0);
}

TEST(Campaign, AKilledSimulatorWorkerLosesOnlyItsEpisodesWhichRunAgainOnTheOtherOne) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto db = env.runs / "c.db";
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");
  const pid_t run = itest::spawn_shell("exec " + dh + " campaign --arms full --cells goal --seeds 1-3 --reruns 1 " +
                                       "--ready-timeout-ms 20000 --db " + db.string() + " > " +
                                       (env.runs / "campaign.log").string() + " 2>&1");
  ASSERT_GT(run, 0);
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (itest::rows_in(db) < 8 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
  ASSERT_GE(itest::rows_in(db), 8u);
  ASSERT_TRUE(deployment.signal("sim_worker_b", SIGKILL));
  int status = 0;
  waitpid(run, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "see " << (env.runs / "campaign.log").string();

  auto store = campaign::CampaignDb::open(db);
  const auto rows = store.rows();
  ASSERT_EQ(rows.size(), 30u) << "every episode recorded once";
  for (const auto& r : rows) EXPECT_FALSE(r.infrastructure) << r.episode_id << ": " << r.reason;
  const auto losses = store.losses();
  ASSERT_GE(losses.size(), 1u) << "local_b had episodes running when it was killed";
  EXPECT_LE(losses.size(), 2u) << "only what local_b's two channels ran";
  for (const auto& l : losses) {
    EXPECT_EQ(l.worker, "local_b");
    EXPECT_NE(l.reason.find("worker local_b lost"), std::string::npos) << l.reason;
  }
  // The plan declares the rule, so a resume under another rule is refused.
  auto [out, code] = itest::run_command(dh + " campaign --arms full --cells goal --seeds 1-3 --reruns 0 --db " +
                                        db.string() + " 2>&1");
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("rerun rule"), std::string::npos) << out;
}
