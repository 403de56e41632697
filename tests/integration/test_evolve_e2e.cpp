// `dh evolve` over real processes (every service of campaign_local.yaml): one round on goal-swap 5 (Figure
// 3's task: the push is refused and pick_place substituted; four of these six seeds fail in the
// substitute), stopped by Ctrl-C in its revision search and run again, SIGKILLed in the candidate's
// campaign and run again. The rerun goes on from where the kill left it: no recorded episode runs again, the
// round ends with the gate's decision in the registry, and the JSON and the report say so. Then `dh transfer`
// sets the parent and the candidate on a fresh block beside their development success.
#include <signal.h>
#include <sys/wait.h>

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign_helpers.hpp"
#include "harness.hpp"

using namespace dh;
using namespace std::chrono_literals;

TEST(EvolveE2E, ARoundKilledInTheCandidatesCampaignResumesAndRegistersItsDecision) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto out = env.runs / "climb";
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");
  const std::string evolve =
      dh + " evolve --library " + (paths::config_dir() / "library").string() +
      " --rounds 1 --cells goal-swap --tasks 5 --dev-seeds 21,22,27,28,33,34 --regression-seeds 41"
      " --no-bare --max-evals 4 --scan-levels 2 --successes 1 --ready-timeout-ms 20000 --out " +
      out.string();

  // Ctrl-C in the revision search: the climb stops within the probes at hand, says where it stopped, and
  // keeps its state for the run that goes on.
  const auto stage = [&] {
    try {
      const auto s = nlohmann::json::parse(std::ifstream(out / "evolve.json"));
      return s["rounds"].empty() ? std::string() : s["rounds"][0]["stage"].get<std::string>();
    } catch (const std::exception&) {
      return std::string();  // not written yet, or being written
    }
  };
  const pid_t stopped =
      itest::spawn_shell("exec " + evolve + " > " + (env.runs / "stopped.log").string() + " 2>&1");
  ASSERT_GT(stopped, 0);
  const auto searching_by = std::chrono::steady_clock::now() + 300s;
  while (stage() != "revise" && std::chrono::steady_clock::now() < searching_by)
    std::this_thread::sleep_for(20ms);
  ASSERT_EQ(stage(), "revise") << std::ifstream(env.runs / "stopped.log").rdbuf();
  kill(stopped, SIGINT);
  int stopped_status = 0;
  const auto stop_by = std::chrono::steady_clock::now() + 180s;
  bool ended = false;
  while (!(ended = waitpid(stopped, &stopped_status, WNOHANG) == stopped) &&
         std::chrono::steady_clock::now() < stop_by)
    std::this_thread::sleep_for(50ms);
  if (!ended) kill(stopped, SIGKILL);
  ASSERT_TRUE(ended) << "dh evolve did not stop on Ctrl-C in its search";
  EXPECT_TRUE(WIFEXITED(stopped_status) && WEXITSTATUS(stopped_status) == 1);
  std::ostringstream stopped_log;
  stopped_log << std::ifstream(env.runs / "stopped.log").rdbuf();
  EXPECT_NE(
      stopped_log.str().find("interrupted in round 1, at its revise stage; run the same command to go on"),
      std::string::npos)
      << stopped_log.str();
  EXPECT_EQ(stage(), "revise");

  const pid_t first = itest::spawn_shell("exec " + evolve + " > " + (env.runs / "first.log").string() + " 2>&1");
  ASSERT_GT(first, 0);
  const auto candidate_db = out / "round-1" / "candidate.db";
  const auto deadline = std::chrono::steady_clock::now() + 300s;
  int status = 0;
  bool exited = false;
  while (itest::rows_in(candidate_db) < 1 && std::chrono::steady_clock::now() < deadline && !exited) {
    exited = waitpid(first, &status, WNOHANG) == first;
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_FALSE(exited) << "dh evolve ended before its candidate's campaign:\n"
                       << std::ifstream(env.runs / "first.log").rdbuf();
  kill(first, SIGKILL);
  waitpid(first, nullptr, 0);
  const auto before = campaign::CampaignDb::read_rows(candidate_db);
  ASSERT_GE(before.size(), 1u) << "the candidate's campaign recorded nothing before the deadline";
  const auto state = nlohmann::json::parse(std::ifstream(out / "evolve.json"));
  ASSERT_EQ(state["rounds"].size(), 1u);
  EXPECT_EQ(state["rounds"][0]["stage"], "candidate") << "killed in the candidate's campaign";
  EXPECT_TRUE(state["rounds"][0]["decision"].is_null());

  auto [json_out, json_status] = itest::run_command(evolve + " --json 2>" + (env.runs / "second.log").string());
  ASSERT_EQ(json_status, 0) << json_out << std::ifstream(env.runs / "second.log").rdbuf();
  const auto j = nlohmann::json::parse(json_out);
  ASSERT_EQ(j["rounds"].size(), 1u) << j.dump();
  const auto& round = j["rounds"][0];
  const std::string decision = round["decision"];
  EXPECT_TRUE(decision == "admitted" || decision == "rejected") << j.dump();
  EXPECT_EQ(round["capability"], "pick_place");
  // The search scanned each parameter at the two ends of its range on the failing states first.
  const auto revision = nlohmann::json::parse(std::ifstream(out / "evolve.json"))["rounds"][0]["revision"];
  EXPECT_GT(revision["scanned"].get<unsigned>(), 0u) << revision.dump();
  EXPECT_EQ(round["admitted"].size() + round["rejected"].size(), 1u);
  EXPECT_FALSE(round["reason"].get<std::string>().empty());
  EXPECT_GT(round["wall_s"].get<double>(), 0.0);
  // The parent succeeds on two of its six episodes; the start is its success.
  EXPECT_NEAR(j["start_success"].get<double>(), 2.0 / 6, 1e-9) << j.dump();
  EXPECT_FALSE(j["final_success"].is_null());

  // What the kill left recorded stays as it was: those episodes were not run again.
  std::map<std::string, std::string> ids;
  for (const auto& r : campaign::CampaignDb::read_rows(candidate_db))
    ids[r.cell + "/" + std::to_string(r.task) + "/" + std::to_string(r.seed)] = r.episode_id;
  EXPECT_EQ(ids.size(), 6u);
  for (const auto& r : before)
    EXPECT_EQ(ids[r.cell + "/" + std::to_string(r.task) + "/" + std::to_string(r.seed)], r.episode_id);
  EXPECT_EQ(itest::rows_in(out / "round-1" / "parent.db"), 6u);

  // The registry holds the one decision; an admitted candidate is a snapshot; the report has the round.
  auto [list, list_status] =
      itest::run_command(dh + " registry list --json --registry " + (out / "registry").string());
  ASSERT_EQ(list_status, 0) << list;
  const auto entries = nlohmann::json::parse(list);
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0]["decision"], decision);
  EXPECT_EQ(entries[0]["capability"], "pick_place");
  EXPECT_EQ(entries[0].contains("snapshot"), decision == "admitted");
  // A gate that passed sent the candidate to the broader round over every cell.
  if (entries[0]["gate"]["pass"].get<bool>()) {
    EXPECT_FALSE(entries[0]["regression"].is_null());
  }
  std::ifstream report(out / "evolve.md");
  const std::string md((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| 1 | "), std::string::npos) << md;
  EXPECT_NE(md.find("![The climb](climb.png)"), std::string::npos) << md;
  EXPECT_TRUE(std::filesystem::exists(out / "climb.png"));

  // Run again on a finished climb: nothing runs, the same answer.
  auto [again, again_status] = itest::run_command(evolve + " --json 2>/dev/null");
  ASSERT_EQ(again_status, 0);
  EXPECT_EQ(nlohmann::json::parse(again)["rounds"], j["rounds"]);

  // The parent and the candidate on a fresh block: their development success comes from the round's
  // databases (nothing runs on the development seeds again), and each runs its one fresh episode.
  const auto round_dir = out / "round-1";
  auto [transfer, transfer_status] = itest::run_command(
      dh + " transfer --snapshots " + (paths::config_dir() / "library").string() + "," +
      (round_dir / "candidate").string() + " --dev-dbs " + (round_dir / "parent.db").string() + "," +
      (round_dir / "candidate.db").string() + " --cells goal-swap --tasks 5 --fresh-seeds 1 --salt 5 --out " +
      (env.runs / "transfer").string() + " --json 2>" + (env.runs / "transfer.log").string());
  ASSERT_EQ(transfer_status, 0) << transfer << std::ifstream(env.runs / "transfer.log").rdbuf();
  const auto t = nlohmann::json::parse(transfer);
  ASSERT_EQ(t["snapshots"].size(), 2u) << t.dump();
  EXPECT_EQ(t["snapshots"][0]["dev_episodes"], 6) << "the parent's development rows are its round's";
  EXPECT_NEAR(t["snapshots"][0]["dev_success"].get<double>(), 2.0 / 6, 1e-9);
  EXPECT_EQ(t["snapshots"][1]["dev_episodes"], 6);
  EXPECT_EQ(t["snapshots"][0]["fresh_episodes"], 1);
  EXPECT_EQ(t["snapshots"][1]["fresh_episodes"], 1);
  EXPECT_FALSE(std::filesystem::exists(env.runs / "transfer" / "dev")) << "a development campaign ran again";
  EXPECT_TRUE(std::filesystem::exists(env.runs / "transfer" / "transfer.md"));
}
