// A capability process replaced while a campaign runs: new commands go to the new instance, commands
// already running finish on the old one, which then drains and exits; no episode is lost or flagged.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "campaign_helpers.hpp"
#include "dh/common/evidence.hpp"
#include "harness.hpp"

using namespace dh;
using namespace std::chrono_literals;


TEST(HotSwap, NewCommandsGoToTheNewInstanceAndNothingIsLost) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto db = env.runs / "swap.db";
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");
  const std::string cmd = "exec " + dh + " campaign --cells goal --tasks 8 --seeds 1-48 --ready-timeout-ms 20000 --db " +
                          db.string() + " --json > " + (env.runs / "campaign.json").string() + " 2>&1";
  pid_t campaign_pid = itest::spawn_shell(cmd), fresh = 0;
  ASSERT_GT(campaign_pid, 0);
  // Whatever fails below, nothing this test started outlives it.
  struct Cleanup {
    pid_t& campaign;
    pid_t& fresh;
    ~Cleanup() {
      if (campaign > 0 && kill(campaign, SIGKILL) == 0) waitpid(campaign, nullptr, 0);
      if (fresh > 0 && kill(fresh, SIGTERM) == 0)
        for (int i = 0; i < 100 && kill(fresh, 0) == 0; ++i) std::this_thread::sleep_for(50ms);
    }
  } cleanup{campaign_pid, fresh};
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (itest::rows_in(db) < 6 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(50ms);
  ASSERT_GE(itest::rows_in(db), 6u);

  const auto [out, status] = itest::run_command(dh + " swap pick_place --json");
  ASSERT_EQ(status, 0) << out;
  const auto swap = nlohmann::json::parse(out);
  fresh = swap["new_pid"].get<pid_t>();
  const std::string old_instance = swap["stopped"][0]["instance"], new_instance = swap["new_instance"];
  EXPECT_TRUE(swap["stopped"][0]["exited"].get<bool>()) << out;
  int wstatus = 0;
  waitpid(campaign_pid, &wstatus, 0);
  campaign_pid = 0;
  ASSERT_TRUE(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 0);

  const auto rows = campaign::CampaignDb::read_rows(db);
  ASSERT_EQ(rows.size(), 48u);
  for (const auto& r : rows) {
    EXPECT_TRUE(r.success) << r.episode_id << ": " << r.outcome << " " << r.reason;
    EXPECT_FALSE(r.infrastructure) << r.episode_id;
  }
  // Every dispatch names its instance; once the new one is chosen, the old one never is again.
  std::vector<std::pair<long long, std::string>> dispatches;
  std::size_t refusals = 0;
  for (const auto& r : rows)
    for (const auto& rec : read_evidence(r.evidence_path)) {
      if (rec["kind"] == "dispatch") dispatches.emplace_back(rec["t_wall_ns"].get<long long>(), rec["instance"]);
      refusals += rec["kind"] == "refusal";
    }
  std::sort(dispatches.begin(), dispatches.end());
  const auto first_new = std::find_if(dispatches.begin(), dispatches.end(),
                                      [&](const auto& d) { return d.second == new_instance; });
  ASSERT_NE(first_new, dispatches.end()) << "no command went to the new instance";
  EXPECT_NE(first_new, dispatches.begin()) << "no command ran on the old instance";
  EXPECT_TRUE(std::all_of(first_new, dispatches.end(), [&](const auto& d) { return d.second == new_instance; }))
      << "a command went to " << old_instance << " after the switch";
  EXPECT_EQ(refusals, 0u);
  const auto exited = deployment.exited();
  EXPECT_NE(std::find(exited.begin(), exited.end(), "cap_pick_place"), exited.end()) << "the old instance still runs";
}

TEST(HotSwap, ANewInstanceThatNeverAnnouncesItselfIsAClearErrorAndTheOldOneStays) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  cli::Deployment deployment({itest::service("cap_pick_place")}, paths::bin_dir(), env.runs / "logs");
  auto [out, status] = itest::run_command(dh + " swap pick_place --library /nonexistent/pick_place.yaml --wait-s 5 2>&1");
  EXPECT_EQ(status, 1) << out;
  EXPECT_NE(out.find("did not announce itself"), std::string::npos) << out;
  EXPECT_NE(out.find("the old instances keep running"), std::string::npos) << out;
  EXPECT_TRUE(deployment.exited().empty()) << "the old instance was stopped";
  std::tie(out, status) = itest::run_command(dh + " swap teleport 2>&1");
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("no executable"), std::string::npos) << out;
}
