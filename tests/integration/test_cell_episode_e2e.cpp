// A whole episode on the robot adapter, as the cell's dry run runs one: the adapter drives the RTDE test
// controller's UR7e (a test double for the metal), standing on the goal kitchen's mount among its objects,
// and the controller is the cell's camera too. The arm's observations carry only the calibrated fixtures
// (the entities file the controller writes); perception sees the objects; the governor plans and grounds
// on what it saw and latches the perceived verdict, for a cell has no oracle; the jaw's gap and contacts
// come from the Robotiq URCap's socket. And the same cell with a protective stop drilled mid-command.
#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../support/unused_port.hpp"
#include "harness.hpp"

namespace dh {
namespace {

using namespace std::chrono_literals;

bool log_says(const std::filesystem::path& log, const std::string& text, std::chrono::seconds within) {
  const auto until = std::chrono::steady_clock::now() + within;
  while (std::chrono::steady_clock::now() < until) {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);)
      if (line.find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(100ms);
  }
  return false;
}

/// The cell as the dry run starts it: the test controller on the goal kitchen (task 1, seed 4, with
/// `drill` arguments), the adapter, governor, planner, pick_place and perception; runs one episode under
/// perception grounding and its verdict, and returns its JSON line and evidence records.
struct CellRun {
  nlohmann::json result;
  std::vector<nlohmann::json> evidence;
  bool has(const std::string& kind) const {
    return std::any_of(evidence.begin(), evidence.end(), [&](const auto& r) { return r["kind"] == kind; });
  }
};

CellRun run_cell(itest::IsolatedEnv& env, const std::vector<std::string>& drill = {}) {
  CellRun run;
  const std::string port = std::to_string(testsupport::unused_port()),
                    script = std::to_string(testsupport::unused_port()),
                    gripper = std::to_string(testsupport::unused_port());
  const std::string entities = (env.runs / "entities.yaml").string();
  std::vector<std::string> controller{
      "--cell", "goal", "--task",        "1",    "--seed",         "4",     "--channel",      "0",
      "--port", port,   "--script-port", script, "--gripper-port", gripper, "--entities-out", entities};
  controller.insert(controller.end(), drill.begin(), drill.end());
  cli::Deployment arm({itest::service("rtde_test_controller", controller)}, paths::bin_dir(),
                      env.runs / "logs");
  if (!log_says(env.runs / "logs" / "rtde_test_controller.log", "serving RTDE", 30s)) {
    ADD_FAILURE() << "the test controller did not come up";
    return run;
  }
  // The test double shares the host with the whole stack (and CI's other tests): a pause of the host is not
  // an arm's silence, so the adapter waits 2 s for it, not the metal's 500 ms.
  cli::Deployment cell(
      {itest::service("robot_adapter",
                      {"--rtde-port", port, "--script-port", script, "--gripper-port", gripper,
                       "--gripper-interface", "robotiq-urcap", "--channel", "0", "--base=-0.56,0,0,0",
                       "--entities", entities, "--timeout-ms", "2000"}),
       itest::service("governor"), itest::service("planner", {"--backend", "rules"}),
       itest::service("cap_pick_place"), itest::service("perception")},
      paths::bin_dir(), env.runs / "logs");
  const std::string dh = (paths::bin_dir() / "dh").string();
  auto [out, status] = itest::run_command(dh +
                                          " run --suite goal --task 1 --seed 4 --arm full-perception "
                                          "--verifier perception --json --ready-timeout-ms 30000");
  if (status != 0) {
    ADD_FAILURE() << out;
    return run;
  }
  run.result = nlohmann::json::parse(out);
  std::ifstream in(run.result["evidence"].get<std::string>());
  for (std::string line; std::getline(in, line);) run.evidence.push_back(nlohmann::json::parse(line));
  return run;
}

TEST(CellEpisode, AWholeEpisodeRunsOnTheArmUnderPerceptionGroundingAndItsVerdict) {
  itest::IsolatedEnv env;
  const CellRun run = run_cell(env);
  ASSERT_FALSE(run.result.is_null());
  EXPECT_TRUE(run.result["success"].get<bool>()) << run.result.dump();
  std::string verifier;
  bool planned_on_perception = false, grounded = false, perceived_true = false;
  for (const auto& r : run.evidence) {
    if (r["kind"] == "episode_start") verifier = r.value("verifier", "");
    planned_on_perception |= r["kind"] == "awaiting_perception" && r.value("for", "") == "planning";
    grounded |= r["kind"] == "grounding" && r.value("result", "") == "grounded";
    perceived_true |= r["kind"] == "perceived_verdict" && r["value"] == true;
  }
  EXPECT_EQ(verifier, "perception");
  EXPECT_TRUE(planned_on_perception) << "the first plan did not wait for what perception saw";
  EXPECT_TRUE(grounded);
  EXPECT_TRUE(perceived_true) << "no perceived verdict latched";
  EXPECT_FALSE(run.has("verdict_event"))
      << "the adapter has no oracle, yet a simulator's verdict was recorded";
}

// The drill: a protective stop the controller takes mid-command ends the episode with its reason,
// at once: the governor hears the seam's typed end, not its own step-stall deadline.
TEST(CellEpisode, AProtectiveStopMidCommandEndsTheEpisodeWithItsReason) {
  itest::IsolatedEnv env;
  const CellRun run = run_cell(env, {"--protective-stop-after-s", "1"});
  ASSERT_FALSE(run.result.is_null());
  EXPECT_FALSE(run.result["success"].get<bool>());
  EXPECT_EQ(run.result["outcome"], "infrastructure") << run.result.dump();
  const std::string reason = run.result["reason"];
  EXPECT_NE(reason.find("the robot seam ended the episode"), std::string::npos) << reason;
  EXPECT_NE(reason.find("protective stop"), std::string::npos) << reason;
  EXPECT_GT(run.result["steps"].get<int>(), 0) << "the arm moved before the stop";
  EXPECT_TRUE(run.has("seam_ended"));
  EXPECT_FALSE(run.has("deadline_missed")) << "the episode waited for a deadline instead";
}

}  // namespace
}  // namespace dh
