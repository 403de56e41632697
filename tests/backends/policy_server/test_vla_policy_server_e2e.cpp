// vla_act's policy-server backend end to end: sim_worker renders the agentview and wrist cameras on
// rt/dh/camera, cap_vla_act asks a real websocket server (fake_policy_server.py, openpi's protocol) for
// every chunk with those images, and the bare arm runs an episode on it. A server that fails every
// request ends the episode with the server's reason, after the bare arm's retry; nothing hangs.
#include <nlohmann/json.hpp>

#include "../../integration/harness.hpp"
#include "dh/common/evidence.hpp"
#include "fake_server.hpp"

using namespace dh;
using nlohmann::json;

namespace {
// The fake server in `mode`, a deployment using it (sim_worker renders both cameras every 5 steps), and
// one bare episode through `dh run`; returns dh run's JSON object with the episode's evidence records
// under "records" (read before the test's runs folder goes).
json bare_episode_on_server(const std::string& mode) {
  itest::IsolatedEnv env;
  test::FakeServer server({"--mode", mode});
  if (!server.running()) return json::object();
  cli::Deployment d({itest::service("sim_worker", {"--channels", "1", "--cameras", "agentview,wrist", "--camera-every", "5"}),
                     itest::service("governor"), itest::service("planner"),
                     itest::service("cap_vla_act", {"--backend", "policy-server", "--server", server.url(),
                                                    "--server-timeout-ms", "5000"})},
                    paths::bin_dir(), env.runs / "logs");
  const auto [out, status] = itest::run_command((paths::bin_dir() / "dh").string() +
                                                " run --suite goal --task 8 --seed 3 --arm bare --json --ready-timeout-ms 20000");
  EXPECT_EQ(status, 0) << out;
  if (status != 0) return json::object();
  json j = json::parse(out);
  j["records"] = read_evidence(j["evidence"].get<std::string>());
  return j;
}
}  // namespace

TEST(VlaPolicyServer, TheBareArmRunsOnAPolicyServerFedWithRenderedCameras) {
  const json j = bare_episode_on_server("normal");
  ASSERT_TRUE(j.contains("evidence"));
  EXPECT_TRUE(j["outcome"] == "success" || j["outcome"] == "budget_exhausted") << j.dump();
  EXPECT_EQ(j["steps"], 300) << "the fake server's actions never solve the task: the policy acts to the budget";
  int failed = 0, grounded = 0;
  for (const auto& r : j["records"]) {
    grounded += r.value("kind", "") == "grounding" && r.value("capability", "") == "vla_act";
    failed += r.value("kind", "") == "command_status" && r.value("state", "") == "failed";
  }
  EXPECT_EQ(grounded, 1) << "one command for the whole episode";
  EXPECT_EQ(failed, 0) << "every chunk came back (the server checks image sizes, state and prompt strictly)";
}

TEST(VlaPolicyServer, AFailingServerEndsTheEpisodeWithItsReason) {
  const json j = bare_episode_on_server("error");
  ASSERT_TRUE(j.contains("evidence"));
  EXPECT_EQ(j["outcome"], "gave_up") << j.dump();
  std::string reason;
  for (const auto& r : j["records"])
    if (r.value("kind", "") == "command_status" && r.value("state", "") == "failed") reason = r.value("reason", "");
  EXPECT_NE(reason.find("fake policy failure: the model is not loaded"), std::string::npos) << reason;
}
