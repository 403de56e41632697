// The fast brain's latency: decide() alone, the latch, and grounding an advisory into a command.
// Run: build/bin/bench_decide  (the paper reports p50 0.046 ms, p99 0.071 ms for its decision step)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include "dh/common/evidence.hpp"
#include "dh/gov/decide.hpp"
#include "dh/gov/grounding.hpp"

using namespace dh;
using namespace dh::gov;

namespace {
// Percentiles over the repetitions' mean times (each repetition times many calls).
double percentile(const std::vector<double>& v, double p) {
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  return s[static_cast<std::size_t>(p * (s.size() - 1) + 0.5)];
}
}  // namespace
#define DH_PERCENTILES                                                                     \
  Repetitions(20)                                                                          \
      ->ComputeStatistics("p50", [](const std::vector<double>& v) { return percentile(v, 0.50); }) \
      ->ComputeStatistics("p99", [](const std::vector<double>& v) { return percentile(v, 0.99); })

static void BM_Decide(benchmark::State& state) {
  DecisionState s;
  s.phase = CommandPhase::Failed;
  s.step = 120;
  s.budget_steps = 300;
  s.failures_of_step = 2;
  s.vla_available = true;
  DecisionLimits limits;
  for (auto _ : state) {
    s.step = (s.step + 1) % 300;
    benchmark::DoNotOptimize(decide(s, limits));
  }
}
BENCHMARK(BM_Decide)->DH_PERCENTILES;

static void BM_LatchAndDecideRunning(benchmark::State& state) {
  VerdictLatch latch;
  DecisionState s;
  s.phase = CommandPhase::Running;
  s.budget_steps = 300;
  std::uint32_t t = 0;
  for (auto _ : state) {
    latch.record(t, false);
    s.latched = latch.decide(t);
    s.step = t % 300;
    benchmark::DoNotOptimize(decide(s, {}));
    t += 10;
  }
}
BENCHMARK(BM_LatchAndDecideRunning)->DH_PERCENTILES;

static void BM_Ground(benchmark::State& state) {
  Registry registry;
  CapabilityInfo info;
  info.capability = "pick_place";
  info.instance = "pick_place@a";
  info.arguments = {"object", "target"};
  info.preconditions = {"distinct_entities", "gripper_empty", "task_goal_unmet"};
  info.parameters = {{"corridor_height", 0.16}, {"approach_height", 0.08}};
  info.cost_steps = 221;
  registry.announce(info);
  Observation obs;
  obs.step = 40;
  for (const char* n : {"bowl", "plate", "cream_cheese", "wine_bottle"}) {
    EntityState e;
    e.name = n;
    e.kind = "box";
    obs.entities.push_back(e);
  }
  Advice a{"p0", false, "pick_place", {{"object", "bowl"}, {"target", "plate"}}, "", "", "rules", false, {}};
  const std::set<std::string> masked;
  const std::map<std::string, std::map<std::string, double>> library;  // announced θ
  const std::map<std::string, std::uint32_t> costs;                     // and cost
  for (auto _ : state) benchmark::DoNotOptimize(ground({a, registry, obs, 260, masked, "ep/c0", 10, library, costs}));
}
BENCHMARK(BM_Ground)->DH_PERCENTILES;

// The decision routine on states recorded in campaign evidence (every "decision" record's "state"),
// replayed in order. DH_BENCH_EVIDENCE names the folder (default runs/benchmark, which
// scripts/benchmark_campaign fills); without recorded states the benchmark reports an error.
static void BM_DecideRecordedStates(benchmark::State& state) {
  static const std::vector<DecisionState> states = [] {
    std::vector<DecisionState> out;
    const char* env = std::getenv("DH_BENCH_EVIDENCE");
    const std::filesystem::path root = env ? env : "runs/benchmark";
    std::error_code ec;
    for (auto it = std::filesystem::recursive_directory_iterator(root, ec);
         !ec && it != std::filesystem::recursive_directory_iterator() && out.size() < 200000; it.increment(ec)) {
      if (it->path().extension() != ".jsonl") continue;
      for (const auto& r : read_evidence(it->path()))
        if (r.value("kind", "") == "decision" && r.contains("state")) out.push_back(state_from_json(r["state"]));
    }
    return out;
  }();
  if (states.empty()) {
    state.SkipWithError("no recorded decision states (set DH_BENCH_EVIDENCE to a folder of evidence files)");
    return;
  }
  const DecisionLimits limits;
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(decide(states[i], limits));
    if (++i == states.size()) i = 0;
  }
  state.counters["states"] = static_cast<double>(states.size());
}
BENCHMARK(BM_DecideRecordedStates)->DH_PERCENTILES;

BENCHMARK_MAIN();
