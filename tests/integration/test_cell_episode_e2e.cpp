// A whole episode on the robot adapter, as the cell's dry run runs one: the adapter drives the RTDE test
// controller's UR7e (a test double for the metal), standing on the goal kitchen's mount among its objects,
// and the controller is the cell's camera too. The arm's observations carry only the calibrated fixtures
// (the entities file the controller writes); perception sees the objects; the governor plans and grounds
// on what it saw and latches the perceived verdict, for a cell has no oracle; the jaw's gap and contacts
// come from the Robotiq URCap's socket.
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

TEST(CellEpisode, AWholeEpisodeRunsOnTheArmUnderPerceptionGroundingAndItsVerdict) {
  itest::IsolatedEnv env;
  const std::string port = std::to_string(testsupport::unused_port()),
                    script = std::to_string(testsupport::unused_port()),
                    gripper = std::to_string(testsupport::unused_port());
  const std::string entities = (env.runs / "entities.yaml").string();
  cli::Deployment arm(
      {itest::service("rtde_test_controller",
                      {"--cell", "goal", "--task", "1", "--seed", "4", "--channel", "0", "--port", port,
                       "--script-port", script, "--gripper-port", gripper, "--entities-out", entities})},
      paths::bin_dir(), env.runs / "logs");
  ASSERT_TRUE(log_says(env.runs / "logs" / "rtde_test_controller.log", "serving RTDE", 30s))
      << "the test controller did not come up";
  cli::Deployment cell(
      {itest::service("robot_adapter", {"--rtde-port", port, "--script-port", script, "--gripper-port",
                                        gripper, "--gripper-interface", "robotiq-urcap", "--channel", "0",
                                        "--base=-0.56,0,0,0", "--entities", entities}),
       itest::service("governor"), itest::service("planner", {"--backend", "rules"}),
       itest::service("cap_pick_place"), itest::service("perception")},
      paths::bin_dir(), env.runs / "logs");
  const std::string dh = (paths::bin_dir() / "dh").string();
  auto [out, status] = itest::run_command(dh +
                                          " run --suite goal --task 1 --seed 4 --arm full-perception "
                                          "--verifier perception --json --ready-timeout-ms 30000");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << j.dump();
  std::ifstream in(j["evidence"].get<std::string>());
  std::string verifier;
  bool planned_on_perception = false, grounded = false, perceived_true = false, oracle = false;
  for (std::string line; std::getline(in, line);) {
    const auto r = nlohmann::json::parse(line);
    if (r["kind"] == "episode_start") verifier = r.value("verifier", "");
    planned_on_perception |= r["kind"] == "awaiting_perception" && r.value("for", "") == "planning";
    grounded |= r["kind"] == "grounding" && r.value("result", "") == "grounded";
    perceived_true |= r["kind"] == "perceived_verdict" && r["value"] == true;
    oracle |= r["kind"] == "verdict_event";
  }
  EXPECT_EQ(verifier, "perception");
  EXPECT_TRUE(planned_on_perception) << "the first plan did not wait for what perception saw";
  EXPECT_TRUE(grounded);
  EXPECT_TRUE(perceived_true) << "no perceived verdict latched";
  EXPECT_FALSE(oracle) << "the adapter has no oracle, yet a simulator's verdict was recorded";
}

}  // namespace
}  // namespace dh
