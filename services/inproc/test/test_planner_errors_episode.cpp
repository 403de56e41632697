// Episodes whose planner errs on purpose (configs/planner_errors.yaml): the errors are drawn the same
// way every run, each one made is in the evidence beside the request's rates, the fast brain runs on, and
// the episode replays bit for bit from its evidence (the commands, not the planner, are re-run).
#include <gtest/gtest.h>

#include <unistd.h>

#include "dh/common/evidence.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/replay.hpp"
#include "dh/inproc/stack.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {

/// The errors an episode's advice records name, in order.
std::vector<std::string> injected(const fs::path& evidence, bool& rates_recorded) {
  std::vector<std::string> out;
  rates_recorded = false;
  for (const auto& r : read_evidence(evidence)) {
    if (r.value("kind", "") == "episode_request") rates_recorded = r.contains("planner_errors");
    if (r.value("kind", "") == "advice" && r.contains("injected_error")) out.push_back(r["injected_error"]);
  }
  return out;
}

}  // namespace

TEST(PlannerErrorsEpisode, ErrorsAreDrawnAlikeRecordedAndTheEpisodeReplays) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("dh_planner_errors_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const auto suites = load_suites(paths::config_dir());
  // long 0: two placements into the basket, so a step can be dropped or repeated.
  const TaskDef& task = find_task(suites, "long", 0);
  inproc::Stack stack(paths::config_dir());
  stack.set_planner_errors(load_planner_errors(paths::config_dir() / "planner_errors.yaml", "heavy"));
  std::size_t made = 0;
  for (unsigned seed = 21; seed <= 24; ++seed) {
    const fs::path one = dir / ("a" + std::to_string(seed) + ".jsonl"), two = dir / ("b" + std::to_string(seed) + ".jsonl");
    const auto a = stack.run(task, seed, "full", one);
    const auto b = stack.run(task, seed, "full", two);
    bool recorded = false;
    const auto errors = injected(one, recorded);
    EXPECT_TRUE(recorded) << "seed " << seed << ": the request's rates are in the evidence";
    EXPECT_EQ(errors, injected(two, recorded)) << "seed " << seed << ": the same draws every run";
    EXPECT_EQ(a.success, b.success);
    EXPECT_EQ(a.steps, b.steps);
    made += errors.size();
    const auto r = inproc::replay(one, {paths::config_dir(), {}, std::nullopt, false, {}});
    EXPECT_TRUE(r.identical) << "seed " << seed << " does not replay";
  }
  EXPECT_GT(made, 0u) << "at 40 % per request, four episodes made no error";
  // Without a profile no advice names an error and the request records no rates.
  inproc::Stack plain(paths::config_dir());
  plain.run(task, 21, "full", dir / "plain.jsonl");
  bool recorded = true;
  EXPECT_TRUE(injected(dir / "plain.jsonl", recorded).empty());
  EXPECT_FALSE(recorded);
  fs::remove_all(dir);
}
