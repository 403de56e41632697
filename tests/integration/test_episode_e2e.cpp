// One full episode through the dh CLI, which starts the local deployment (four processes on DDS).
#include <nlohmann/json.hpp>

#include "dh/common/evidence.hpp"
#include "harness.hpp"

using namespace dh;

TEST(EpisodeEndToEnd, BowlOnPlateThroughRealProcesses) {
  itest::IsolatedEnv env;
  const auto dh = paths::bin_dir() / "dh";
  const auto [out, status] = itest::run_command(dh.string() + " run --suite goal --task 8 --seed 2 --json");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << out;
  EXPECT_GT(j["steps"].get<int>(), 100);
  EXPECT_LE(j["steps"].get<int>(), 300);
  const auto records = read_evidence(j["evidence"].get<std::string>());
  std::map<std::string, int> kinds;
  for (const auto& r : records) ++kinds[r["kind"]];
  for (const char* k : {"episode_start", "plan_request", "advice", "grounding", "dispatch", "command_status",
                        "decision", "verdict_event", "episode_end"})
    EXPECT_GT(kinds[k], 0) << "evidence has no '" << k << "' record";
  EXPECT_GE(kinds["decision"], 10) << "a decision every 10 steps";
  const auto& last = records.back();
  EXPECT_EQ(last["kind"], "episode_end");
  EXPECT_TRUE(last["latched"].get<bool>());
  EXPECT_EQ(last["outcome"], "success");
}

// `--robot ur7e`: the simulator worker puts the UR7e on the scene's mount; the rest of the stack is the same.
TEST(EpisodeEndToEnd, TheUr7eOnTheScenesMountThroughRealProcesses) {
  itest::IsolatedEnv env;
  const auto dh = paths::bin_dir() / "dh";
  const auto [out, status] =
      itest::run_command(dh.string() + " run --suite goal --task 1 --seed 21 --robot ur7e --json");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << out;
  const auto records = read_evidence(j["evidence"].get<std::string>());
  ASSERT_FALSE(records.empty());
  EXPECT_EQ(records.front()["kind"], "episode_request");
  EXPECT_EQ(records.front().value("robot", ""), "ur7e");
}

TEST(EpisodeEndToEnd, BadInputGetsAClearErrorAndNonZeroExit) {
  itest::IsolatedEnv env;
  const auto dh = paths::bin_dir() / "dh";
  auto [out, status] = itest::run_command(dh.string() + " run --suite nope --task 8 --seed 1 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("unknown suite 'nope'"), std::string::npos) << out;
  std::tie(out, status) = itest::run_command(dh.string() + " run --suite goal --task 42 --seed 1 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("has no task 42"), std::string::npos) << out;
  std::tie(out, status) = itest::run_command(dh.string() + " run --suite goal --task 8 --seed 1 --robot kuka 2>&1");
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("no robot 'kuka'"), std::string::npos) << out;
  EXPECT_NE(out.find("robots: "), std::string::npos) << out;
  std::tie(out, status) = itest::run_command(dh.string() + " run --suite goal --task 8 --seed -4 2>&1");
  EXPECT_NE(status, 0);
  std::tie(out, status) = itest::run_command("DH_CONFIG_DIR=/nonexistent " + dh.string() + " tasks 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("/nonexistent/suites"), std::string::npos) << out;
}

TEST(EpisodeEndToEnd, TasksListsTheSuiteAsJson) {
  itest::IsolatedEnv env;
  const auto [out, status] = itest::run_command((paths::bin_dir() / "dh").string() + " tasks --json");
  ASSERT_EQ(status, 0);
  const auto j = nlohmann::json::parse(out);
  ASSERT_TRUE(j.is_array());
  bool found = false;
  for (const auto& t : j)
    found |= t["suite"] == "goal" && t["task"] == 8 && t["instruction"] == "put the bowl on the plate" && t["budget"] == 300;
  EXPECT_TRUE(found) << out;
}

// One deployment serves many episodes: more than Fast DDS's default of 10 instances per topic, on
// both channels, with idle channels' lease deadlines lapsing between episodes.
TEST(EpisodeEndToEnd, TwentySeedsOnOneDeploymentAllSucceed) {
  itest::IsolatedEnv env;
  cli::Deployment d(cli::load_launch_file(paths::home() / "deploy" / "local.yaml"), paths::bin_dir(), env.runs / "logs");
  const auto dh = paths::bin_dir() / "dh";
  int ok = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    const auto [out, status] = itest::run_command(dh.string() + " run --suite goal --task 8 --seed " +
                                                  std::to_string(seed) + " --json --ready-timeout-ms 20000 --timeout 60");
    ASSERT_EQ(status, 0) << out;
    const auto j = nlohmann::json::parse(out);
    ok += j["success"].get<bool>();
    EXPECT_TRUE(j["success"].get<bool>()) << "seed " << seed << ": " << j["outcome"] << " " << j["reason"];
  }
  EXPECT_GE(ok, 18);
  // cap_vla_act ends at start without a trained weight file (this runs folder has none); nothing else may.
  for (const auto& name : d.exited()) EXPECT_EQ(name, "cap_vla_act") << "service '" << name << "' exited";
}
