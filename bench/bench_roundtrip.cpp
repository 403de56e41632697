// Action -> observation round trip over DDS on loopback against a real sim_worker process: the time
// from writing the action of step t to receiving observation t+1 (DDS both ways + one 50 ms physics
// step of 25 MuJoCo substeps). Prints p50/p90/p99/max in microseconds and the in-process physics step
// alone, so the transport's share can be read off. Exits non-zero if any step is lost.
// Run: build/bin/bench_roundtrip [episodes]   (each episode is 299 steps)
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <thread>

#include "dh/cli/launcher.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

double pct(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
}

int run(int episodes) {
  if (!std::getenv("DH_DOMAIN_ID")) setenv("DH_DOMAIN_ID", "231", 1);
  const auto logs = std::filesystem::temp_directory_path() / "dh_bench_logs";
  cli::Deployment sim({{"sim_worker", "sim_worker", {}}}, paths::bin_dir(), logs);
  dds::Participant p("bench");
  std::mutex m;
  std::condition_variable cv;
  bool idle = false;
  std::string episode;
  std::int64_t step = -1;
  dds::Reader<msg::ChannelStatusPubSubType> ch(p, topics::kChannelStatus, dds::Qos::ChannelStatus,
      {[&](const msg::ChannelStatus& s, const auto&) { std::lock_guard l(m); idle |= s.state() == msg::CHANNEL_IDLE; cv.notify_all(); }, {}, {}});
  dds::Reader<msg::ObservationPubSubType> obs(p, topics::kObservation, dds::Qos::Observation,
      {[&](const msg::Observation& o, const auto&) { std::lock_guard l(m); if (o.episode_id() == episode) step = o.step(); cv.notify_all(); }, {}, {}});
  dds::Writer<msg::EpisodeRequestPubSubType> req(p, topics::kEpisodeRequest, dds::Qos::Episode);
  dds::Writer<msg::LeasePubSubType> lease(p, topics::kLease, dds::Qos::Lease);
  dds::Writer<msg::ActionPubSubType> act(p, topics::kAction, dds::Qos::Action);
  {
    std::unique_lock l(m);
    if (!cv.wait_for(l, std::chrono::seconds(20), [&] { return idle && act.matched() && lease.matched() && req.matched(); })) {
      std::fprintf(stderr, "sim_worker did not come up (logs in %s)\n", logs.c_str());
      return 1;
    }
  }
  std::vector<double> rtt_us;
  int lost = 0;
  for (int e = 0; e < episodes; ++e) {
    {
      std::lock_guard l(m);
      episode = "bench-" + std::to_string(e);
      step = -1;
    }
    msg::EpisodeRequest r;
    r.channel(0);
    r.episode_id(episode);
    r.suite("goal");
    r.task(8);
    r.seed(e + 1);
    r.budget_steps(300);
    req.write(r);
    msg::Lease ls;
    ls.channel(0);
    ls.episode_id(episode);
    ls.command_id("bench");
    ls.valid_until_step(100000);
    ls.budget_until_step(100000);
    lease.write(ls);
    {
      std::unique_lock l(m);
      cv.wait_for(l, std::chrono::seconds(10), [&] { return step == 0; });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // let the lease land first
    for (std::uint32_t t = 0; t < 299; ++t) {
      // The lease has a 1 s deadline (QoS): renew it every 10 steps, outside the timed span, as a governor does.
      if (t % 10 == 0) lease.write(ls);
      msg::Action a;
      a.channel(0);
      a.episode_id(episode);
      a.command_id("bench");
      a.step(t);
      a.a({0.1 * std::sin(t * 0.1), 0.1 * std::cos(t * 0.1), 0, 0, 0, 0, -1});
      const auto t0 = Clock::now();
      act.write(a);
      std::unique_lock l(m);
      if (!cv.wait_for(l, std::chrono::seconds(2), [&] { return step == t + 1; })) {
        ++lost;
        break;
      }
      rtt_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    }
  }
  // The physics step alone, in process, on the same scene.
  const auto suites = load_suites(paths::config_dir());
  const auto& task = find_task(suites, "goal", 8);
  sim::Workcell cell(sim::load_scene(task.scene_file));
  cell.reset(1, task.goal);
  std::vector<double> phys_us;
  for (int t = 0; t < 299; ++t) {
    const auto t0 = Clock::now();
    cell.step({0.1 * std::sin(t * 0.1), 0.1 * std::cos(t * 0.1), 0, 0, 0, 0, -1});
    cell.observe();
    phys_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  if (rtt_us.empty()) {
    std::fprintf(stderr, "no round trip completed\n");
    return 1;
  }
  std::printf("action->observation round trip over DDS (loopback, sim_worker process), %zu steps:\n", rtt_us.size());
  std::printf("  p50 %.0f us  p90 %.0f us  p99 %.0f us  max %.0f us\n", pct(rtt_us, 0.5), pct(rtt_us, 0.9),
              pct(rtt_us, 0.99), pct(rtt_us, 1.0));
  std::printf("physics step + observe in process (25 x 2 ms substeps), %zu steps:\n", phys_us.size());
  std::printf("  p50 %.0f us  p99 %.0f us\n", pct(phys_us, 0.5), pct(phys_us, 0.99));
  std::printf("transport and serialization share at p50: %.0f us\n", pct(rtt_us, 0.5) - pct(phys_us, 0.5));
  if (lost) std::fprintf(stderr, "%d step(s) lost\n", lost);
  return lost ? 1 : 0;
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc > 1 ? std::atoi(argv[1]) : 3); }
