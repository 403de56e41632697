// Campaign throughput and harness overhead: runs a real campaign (`dh campaign`) against a fresh
// deployment of W simulator workers x K channels, then sets its wall time against the time the same
// episodes spent inside MuJoCo (reset, settling and steps, measured by the workers).
//   bench_campaign [seeds=1-5] [cells=goal,goal-task] [workers=1] [channels_per_worker=1]
// Wall time is the campaign's own (first request → last episode recorded), so deployment start-up is
// not in it. Physics is what the workers measured around MuJoCo: reset and settling, IK, the joint
// controller and the substeps. With one channel, wall / physics is the harness's overhead over that
// (DDS, governor, planner, capability, database); with more channels it shows what parallel channels buy.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "dh/campaign/db.hpp"
#include "dh/cli/launcher.hpp"
#include "dh/common/paths.hpp"

using namespace dh;

int main(int argc, char** argv) {
  const std::string seeds = argc > 1 ? argv[1] : "1-5";
  const std::string cells = argc > 2 ? argv[2] : "goal,goal-task";
  const int workers = argc > 3 ? std::stoi(argv[3]) : 1;
  const int per_worker = argc > 4 ? std::stoi(argv[4]) : 1;
  const auto runs = std::filesystem::temp_directory_path() / ("dh_bench_campaign_" + std::to_string(getpid()));
  std::filesystem::create_directories(runs);
  setenv("DH_RUNS_DIR", runs.c_str(), 1);

  std::vector<cli::ServiceSpec> services;
  for (int w = 0; w < workers; ++w)
    services.push_back({"sim_worker_" + std::to_string(w), "sim_worker",
                        {"--channels", std::to_string(per_worker), "--first-channel", std::to_string(w * per_worker),
                         "--name", "bench_" + std::to_string(w)}});
  services.push_back({"governor", "governor", {}});
  services.push_back({"planner", "planner", {"--backend", "rules"}});
  for (const char* cap : {"cap_pick_place", "cap_push", "cap_slide_drawer", "cap_turn_knob", "cap_swing_door", "cap_recovery"})
    services.push_back({cap, cap, {}});
  cli::Deployment deployment(services, paths::bin_dir(), runs / "logs");

  const auto db = runs / "bench.db";
  const std::string cmd = (paths::bin_dir() / "dh").string() + " campaign --arms full --cells " + cells + " --seeds " +
                          seeds + " --db " + db.string() + " --ready-timeout-ms 20000 --json";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (p && std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = p ? pclose(p) : -1;
  if (status != 0) {
    std::cerr << "bench_campaign: `" << cmd << "` failed (status " << status << "); logs in " << runs << "\n" << out;
    return 1;
  }
  // The campaign's own clock: first request sent to last episode recorded (no deployment start-up).
  const double wall = nlohmann::json::parse(out)["campaign"]["run_wall_s"].get<double>();
  const auto rows = campaign::CampaignDb::read_rows(db);
  double physics = 0;
  std::size_t steps = 0, successes = 0;
  for (const auto& r : rows) {
    if (r.physics_s <= 0) {
      std::cerr << "bench_campaign: episode " << r.episode_id << " has no physics time; the ratio would be wrong\n";
      return 1;
    }
    physics += r.physics_s;
    steps += r.steps;
    successes += r.success;
  }
  const int channels = workers * per_worker;
  const nlohmann::json j{{"episodes", rows.size()},
                         {"successes", successes},
                         {"steps", steps},
                         {"channels", channels},
                         {"campaign_wall_s", wall},
                         {"wall_per_100_episodes_s", 100.0 * wall / rows.size()},
                         {"physics_s", physics},
                         {"physics_ms_per_step", 1000.0 * physics / steps},
                         {"wall_over_physics", wall / physics},
                         {"episodes_per_s", rows.size() / wall}};
  std::cout << j.dump() << "\n";
  std::cerr << rows.size() << " episodes (" << steps << " steps) on " << channels << " channel(s): campaign wall "
            << wall << " s = " << 100.0 * wall / rows.size() << " s per 100 episodes; MuJoCo time " << physics
            << " s; wall / physics = " << wall / physics << "\n";
  std::filesystem::remove_all(runs);
  return 0;
}
