// Developer probe: prints the outcome of pick_place on seeds 1..N in process. Usage: probe_pick_place [N]
#include <cstdio>
#include <cstdlib>

#include "inprocess_episode.hpp"

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 20;
  const auto suites = dh::load_suites(dh::paths::config_dir());
  const auto& task = dh::find_task(suites, "goal", 8);
  dh::sim::Workcell cell(dh::sim::load_scene(task.scene_file));
  int ok = 0;
  for (int seed = 1; seed <= n; ++seed) {
    const auto r = dh::test::run_pick_place(cell, task, seed, "bowl", "plate");
    ok += r.success;
    std::printf("seed %2d success=%d first=%d steps=%d status=%d stage=%s safety=%d %s\n", seed, r.success,
                r.first_success_step, r.steps, static_cast<int>(r.status), r.stage.c_str(), r.safety_events,
                r.reason.c_str());
  }
  std::printf("%d/%d\n", ok, n);
}
