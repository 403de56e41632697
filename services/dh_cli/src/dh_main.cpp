// dh: the user's command line.
//   dh tasks [--json]                               suites and tasks with their instructions
//   dh run --suite S --task N --seed K [--json]     one episode on a live deployment (starts the local
//                                                   one from deploy/local.yaml when none answers)
//   dh launch [FILE]                                runs a deployment in the foreground until Ctrl-C
// Exit codes: 0 an episode result was received (success or not: see the output), 1 infrastructure
// failure (no deployment, no result in time), 2 bad input (unknown suite/task, bad config).
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <ctime>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "dh/cli/launcher.hpp"
#include "dh/common/config.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

int cmd_tasks(bool json) {
  const auto suites = load_suites(paths::config_dir());
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [name, s] : suites)
    for (const auto& [id, t] : s.tasks) {
      if (json) {
        out.push_back({{"suite", name}, {"task", id}, {"instruction", t.instruction}, {"budget", t.budget_steps},
                       {"modelled_on", s.modelled_on}});
      } else {
        std::cout << name << "  " << id << "  budget " << t.budget_steps << "  " << t.instruction << "\n";
      }
    }
  if (json) std::cout << out.dump(2) << "\n";
  return 0;
}

/// What a client sees of a deployment: idle channels, announced capabilities, episode results.
class Client {
 public:
  explicit Client(dds::Participant& p)
      : request_(p, topics::kEpisodeRequest, dds::Qos::Episode),
        channels_(p, topics::kChannelStatus, dds::Qos::Episode,
                  {[this](const msg::ChannelStatus& s, const auto&) {
                     std::lock_guard l(m_);
                     idle_[s.channel()] = s.state() == msg::CHANNEL_IDLE;
                     cv_.notify_all();
                   }, {}, {}}),
        caps_(p, topics::kAnnounce, dds::Qos::Announce,
              {[this](const msg::CapabilityAnnounce& a, const auto&) {
                 std::lock_guard l(m_);
                 capabilities_.insert(a.capability());
                 cv_.notify_all();
               }, {}, {}}),
        results_(p, topics::kEpisodeResult, dds::Qos::Episode,
                 {[this](const msg::EpisodeResult& r, const auto&) {
                    std::lock_guard l(m_);
                    results_seen_[r.episode_id()] = r;
                    cv_.notify_all();
                  }, {}, {}}) {}

  /// An idle channel once a governor and a simulator listen and `capability` is announced.
  std::optional<std::uint32_t> wait_ready(const std::string& capability, std::optional<std::uint32_t> want,
                                          std::chrono::milliseconds timeout) {
    std::unique_lock l(m_);
    std::optional<std::uint32_t> found;
    cv_.wait_for(l, timeout, [&] {
      // The episode request needs its two readers: the simulator channel and the governor.
      if (request_.matched() < 2 || !capabilities_.count(capability)) return false;
      for (const auto& [ch, idle] : idle_)
        if (idle && (!want || *want == ch)) {
          found = ch;
          return true;
        }
      return false;
    });
    return found;
  }

  void request(const msg::EpisodeRequest& r) { request_.write(r); }

  std::optional<msg::EpisodeResult> wait_result(const std::string& episode, std::chrono::milliseconds timeout) {
    std::unique_lock l(m_);
    const auto deadline = Clock::now() + timeout;
    while (!results_seen_.count(episode) && !shutdown_requested() && Clock::now() < deadline)
      cv_.wait_until(l, std::min(deadline, Clock::now() + std::chrono::milliseconds(200)));
    if (!results_seen_.count(episode)) return std::nullopt;
    return results_seen_.at(episode);
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::uint32_t, bool> idle_;
  std::set<std::string> capabilities_;
  std::map<std::string, msg::EpisodeResult> results_seen_;
  dds::Writer<msg::EpisodeRequestPubSubType> request_;
  dds::Reader<msg::ChannelStatusPubSubType> channels_;
  dds::Reader<msg::CapabilityAnnouncePubSubType> caps_;
  dds::Reader<msg::EpisodeResultPubSubType> results_;
};

std::string episode_id(const std::string& suite, unsigned task, unsigned seed) {
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%S", std::gmtime(&now));
  return suite + "-t" + std::to_string(task) + "-s" + std::to_string(seed) + "-" + stamp + "-" +
         std::to_string(getpid());
}

int cmd_run(const std::string& suite, unsigned task, unsigned seed, std::optional<std::uint32_t> channel,
            bool json, unsigned timeout_s, const std::string& launch_file, unsigned ready_ms) {
  const auto suites = load_suites(paths::config_dir());
  const TaskDef& t = find_task(suites, suite, task);
  dds::Participant participant("dh_cli");
  Client client(participant);
  // The capability the embedded planner will need first; the deployment is ready when it is announced.
  const std::string needed = "pick_place";
  std::unique_ptr<cli::Deployment> local;
  auto ch = client.wait_ready(needed, channel, std::chrono::milliseconds(ready_ms));
  if (!ch) {
    const auto file = launch_file.empty() ? paths::home() / "deploy" / "local.yaml" : std::filesystem::path(launch_file);
    if (!json) std::cerr << "no deployment answered; starting " << file.string() << "\n";
    local = std::make_unique<cli::Deployment>(cli::load_launch_file(file), paths::bin_dir(), paths::runs_dir() / "logs");
    ch = client.wait_ready(needed, channel, std::chrono::seconds(20));
    if (!ch) {
      std::cerr << "error: the local deployment did not become ready in 20 s; see logs in "
                << local->log_dir().string() << "\n";
      return 1;
    }
    // Let the governor's own discovery of the capability and planner settle.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  msg::EpisodeRequest r;
  r.channel(*ch);
  r.episode_id(episode_id(suite, task, seed));
  r.suite(suite);
  r.task(task);
  r.seed(seed);
  r.arm("full");
  r.instruction(t.instruction);
  r.budget_steps(t.budget_steps);
  const auto t0 = Clock::now();
  client.request(r);
  if (!json) std::cerr << "episode " << r.episode_id() << " on channel " << *ch << ": " << t.instruction << "\n";
  const auto res = client.wait_result(r.episode_id(), std::chrono::seconds(timeout_s));
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!res) {
    std::cerr << "error: no result for episode " << r.episode_id() << " within " << timeout_s << " s\n";
    return 1;
  }
  if (json) {
    nlohmann::json j{{"success", res->success()}, {"steps", res->steps()}, {"evidence", res->evidence_path()},
                     {"outcome", res->outcome()}, {"reason", res->reason()}, {"episode_id", res->episode_id()},
                     {"suite", suite}, {"task", task}, {"seed", seed}, {"channel", *ch},
                     {"budget", t.budget_steps}, {"decisions", res->decisions()}, {"refusals", res->refusals()},
                     {"wall_s", wall}};
    std::cout << j.dump() << "\n";
  } else {
    std::cout << (res->success() ? "SUCCESS" : "FAILURE") << "  " << suite << "/" << task << " seed " << seed
              << "  steps " << res->steps() << "/" << t.budget_steps << "  outcome " << res->outcome() << " ("
              << res->reason() << ")\n"
              << "evidence " << res->evidence_path() << "\n";
  }
  return 0;
}

int cmd_launch(const std::string& file) {
  install_shutdown_handlers();
  const auto path = file.empty() ? paths::home() / "deploy" / "local.yaml" : std::filesystem::path(file);
  cli::Deployment d(cli::load_launch_file(path), paths::bin_dir(), paths::runs_dir() / "logs");
  std::cerr << "deployment " << path.string() << " running (logs in " << d.log_dir().string() << "); Ctrl-C stops it\n";
  while (!shutdown_requested()) {
    for (const auto& name : d.exited()) std::cerr << "service '" << name << "' exited\n";
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return 0;
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) {
  CLI::App app{"dh: DynaHarness command line"};
  app.require_subcommand(1);
  bool json = false;
  auto* tasks = app.add_subcommand("tasks", "list suites and tasks");
  tasks->add_flag("--json", json, "one JSON list on stdout");
  std::string suite, launch_file;
  unsigned task = 0, seed = 0, timeout_s = 180, ready_ms = 2500;
  std::optional<std::uint32_t> channel;
  auto* run = app.add_subcommand("run", "run one episode");
  run->add_option("--suite", suite, "suite name (see dh tasks)")->required();
  run->add_option("--task", task, "task number in the suite")->required();
  run->add_option("--seed", seed, "seed fixing the initial state (non-negative integer)")->required();
  run->add_option("--channel", channel, "simulator channel to use (default: any idle one)");
  run->add_option("--timeout", timeout_s, "seconds to wait for the episode's result");
  run->add_option("--ready-timeout-ms", ready_ms, "how long to look for a live deployment before starting one");
  run->add_option("--launch", launch_file, "launch file to start when no deployment answers");
  run->add_flag("--json", json, "one JSON object on stdout");
  std::string deploy;
  auto* launch = app.add_subcommand("launch", "run a deployment until Ctrl-C");
  launch->add_option("file", deploy, "launch YAML (default deploy/local.yaml)");
  CLI11_PARSE(app, argc, argv);
  try {
    if (*tasks) return dh::cmd_tasks(json);
    if (*run) return dh::cmd_run(suite, task, seed, channel, json, timeout_s, launch_file, ready_ms);
    if (*launch) return dh::cmd_launch(deploy);
  } catch (const dh::ConfigError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
