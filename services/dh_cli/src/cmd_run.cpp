#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "client.hpp"
#include "commands.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/clock.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/scene.hpp"

namespace dh::cli {

namespace {
std::string episode_id(const std::string& suite, unsigned task, unsigned seed) {
  return suite + "-t" + std::to_string(task) + "-s" + std::to_string(seed) + "-" + run_tag();
}
}  // namespace

int cmd_run(const RunArgs& a) {
  const auto suites = load_suites(paths::config_dir());
  const TaskDef& t = find_task(suites, a.suite, a.task);
  find_arm(load_arms(paths::config_dir() / "governor.yaml"), a.arm);
  if (!a.robot.empty()) sim::robot_profile(a.robot);  // an unknown robot is named before anything starts
  const cap::LibraryTheta library =
      cap::load_library_theta(a.library.empty() ? paths::config_dir() / "library" : std::filesystem::path(a.library));
  dds::Participant participant("dh_cli");
  Client client(participant);
  std::unique_ptr<Deployment> local;
  const auto ch = ensure_deployment(client, ready_capability({a.arm}), a.channel, a.launch_file, std::chrono::milliseconds(a.ready_ms), a.json, local);
  if (!ch) return 1;
  msg::EpisodeRequest r;
  r.channel(*ch);
  r.episode_id(episode_id(a.suite, a.task, a.seed));
  r.suite(a.suite);
  r.task(a.task);
  r.seed(a.seed);
  r.cell(a.suite);
  r.arm(a.arm);
  r.instruction(a.instruction.empty() ? instruction_for(t, a.seed) : a.instruction);
  r.budget_steps(t.budget_steps);
  set_library(r, library);
  set_settings(r, arm_settings(paths::config_dir(), {a.arm}).at(a.arm));
  r.planner_errors(convert::to_msg(planner_errors(a.planner_errors)));
  r.goal(goal_terms(t));
  r.verifier(convert::to_msg(parse_verifier(a.verifier)));
  r.robot(a.robot);
  const auto t0 = std::chrono::steady_clock::now();
  client.request(r);
  if (!a.json) std::cerr << "episode " << r.episode_id() << " on channel " << *ch << ": " << r.instruction() << "\n";
  const auto res = client.wait_result(r.episode_id(), std::chrono::seconds(a.timeout_s));
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!res) {
    std::cerr << "error: no result for episode " << r.episode_id() << " within " << a.timeout_s << " s\n";
    return 1;
  }
  if (a.json) {
    nlohmann::json j{{"success", res->success()},
                     {"steps", res->steps()},
                     {"evidence", res->evidence_path()},
                     {"outcome", to_string(convert::from_msg(res->outcome()))},
                     {"reason", res->reason()},
                     {"episode_id", res->episode_id()},
                     {"suite", a.suite},
                     {"task", a.task},
                     {"seed", a.seed},
                     {"arm", a.arm},
                     {"channel", *ch},
                     {"budget", t.budget_steps},
                     {"decisions", res->decisions()},
                     {"refusals", res->refusals()},
                     {"capabilities_missing", res->capabilities_missing()},
                     {"wall_s", wall}};
    std::cout << j.dump() << "\n";
  } else {
    std::cout << (res->success() ? "SUCCESS" : "FAILURE") << "  " << a.suite << "/" << a.task << " seed " << a.seed
              << "  steps " << res->steps() << "/" << t.budget_steps << "  outcome " << to_string(convert::from_msg(res->outcome())) << " ("
              << res->reason() << ")\n"
              << "evidence " << res->evidence_path() << "\n";
    for (const auto& c : res->capabilities_missing())
      std::cout << "warning: arm " << a.arm << " ran without " << c
                << " (no live instance when it started)\n";
  }
  return 0;
}

}  // namespace dh::cli
