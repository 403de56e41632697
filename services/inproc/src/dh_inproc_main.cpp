// dh_inproc: runs episodes of the whole stack in one process, without DDS (see dh/inproc/stack.hpp), and
// prints one line per episode and the success per cell and task. For developing skills and planner rules;
// the figures that count come from `dh campaign` over the services.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <map>

#include "dh/campaign/plan.hpp"
#include "dh/cap/vla_act.hpp"
#include "dh/common/paths.hpp"
#include "dh/inproc/stack.hpp"

int main(int argc, char** argv) {
  CLI::App app{"dh_inproc: episodes of the whole stack in one process (no DDS)"};
  std::string cells = "goal", tasks = "0-9", seeds = "1-5", arm = "full", out = "runs/inproc", policy, library, robot;
  bool quiet = false;
  app.add_option("--cells", cells, "comma-separated cells (goal, goal-task, goal-swap, long, ...)");
  app.add_option("--tasks", tasks, "task ids, e.g. 0-9 or 1,3");
  app.add_option("--seeds", seeds, "seeds, e.g. 21-40");
  app.add_option("--arm", arm, "arm of configs/governor.yaml");
  app.add_option("--out", out, "evidence folder");
  app.add_option("--policy", policy, "embedded policy weight file: serve vla_act with it (dh train-policy)");
  app.add_option("--library", library, "capability library folder (default configs/library)");
  app.add_option("--robot", robot, "the arm on the scene's mount, a profile of configs/robots (default: the scene's own)");
  app.add_flag("--quiet", quiet, "only the summary");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto suites = dh::load_suites(dh::paths::config_dir());
    const auto library_dir = library.empty() ? dh::paths::config_dir() / "library" : std::filesystem::path(library);
    dh::inproc::Stack stack(dh::paths::config_dir(), library_dir);
    stack.set_robot(robot);
    if (!policy.empty())
      stack.add_capability(dh::cap::vla_act_def(std::make_shared<dh::cap::EmbeddedPolicy>(dh::policy::load_policy(policy))),
                           library_dir);
    std::map<std::string, std::pair<int, int>> per_task, per_cell;
    int ok = 0, n = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const auto task_ids = dh::campaign::parse_numbers(tasks, "--tasks");
    const auto seed_ids = dh::campaign::parse_numbers(seeds, "--seeds");
    for (const std::string& cell : dh::campaign::parse_list(cells, "--cells")) {
      for (unsigned t : task_ids)
        for (unsigned seed : seed_ids) {
          const dh::TaskDef& task = dh::find_task(suites, cell, t);
          const auto ev = std::filesystem::path(out) / cell / (std::to_string(t) + "_" + std::to_string(seed) + ".jsonl");
          const auto r = stack.run(task, seed, arm, ev);
          ok += r.success;
          ++n;
          auto& pt = per_task[cell + "[" + std::to_string(t) + "]"];
          pt.first += r.success;
          ++pt.second;
          auto& pc = per_cell[cell];
          pc.first += r.success;
          ++pc.second;
          if (!quiet)
            std::printf("%-10s %d seed %-3u %-16s steps %-4u %s\n", cell.c_str(), t, seed, to_string(r.outcome), r.steps,
                        r.reason.c_str());
        }
    }
    for (const auto& [k, v] : per_task) std::printf("%-14s %d/%d\n", k.c_str(), v.first, v.second);
    for (const auto& [k, v] : per_cell) std::printf("cell %-10s %d/%d\n", k.c_str(), v.first, v.second);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("all %d/%d (%.1f %%) in %.1f s\n", ok, n, n ? 100.0 * ok / n : 0.0, s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dh_inproc: %s\n", e.what());
    return 1;
  }
}
