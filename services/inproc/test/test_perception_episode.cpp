// An arm that grounds from perception on the in-process bus: the perception service's core looks at the
// bus's workcell through its RGB-D camera, the governor plans and grounds on what it saw, every run of the
// same episode takes the same steps, its skills act again on the recorded estimates in a replay, and the
// episode resumes from a command's start with the perceived world its snapshot holds.
#include <gtest/gtest.h>
#include <unistd.h>

#include "dh/common/evidence.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/recording.hpp"
#include "dh/inproc/replay.hpp"
#include "dh/inproc/stack.hpp"
#include "dh/sim/state_log.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {

constexpr unsigned kTask = 8;  // goal 8, "put the bowl on the plate"

/// The evidence's records as they would compare between two runs: the kinds in order, with each record's
/// step, and the grounded commands' arguments.
std::vector<std::string> trace(const fs::path& evidence) {
  std::vector<std::string> out;
  for (const auto& r : read_evidence(evidence)) {
    std::string line = r.value("kind", "") + "@" + std::to_string(r.value("step", 0u));
    if (r.contains("args")) line += " " + r["args"].dump();
    out.push_back(std::move(line));
  }
  return out;
}

}  // namespace

TEST(PerceptionEpisode, GroundsOnWhatTheCameraSawTakesTheSameStepsEveryRunReplaysAndResumesFromACommand) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("dh_perception_episode_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const auto suites = load_suites(paths::config_dir());
  const TaskDef& task = find_task(suites, "goal", kTask);
  inproc::Stack stack(paths::config_dir());

  const auto first = stack.run(task, 21, "full-perception", dir / "a.jsonl");
  ASSERT_TRUE(first.success) << first.reason;
  bool waited = false, perceived = false;
  for (const auto& r : read_evidence(dir / "a.jsonl")) {
    waited |= r.value("kind", "") == "awaiting_perception";
    perceived |= r.value("kind", "") == "snapshot" && r["machine"].contains("perceived_world") &&
                 !r["machine"]["perceived_world"]["latest"].is_null();
  }
  EXPECT_TRUE(waited) << "the first plan waits for the camera's first frame";
  EXPECT_TRUE(perceived) << "a dispatch's snapshot holds the frames taken in";

  const auto second = stack.run(task, 21, "full-perception", dir / "b.jsonl");
  EXPECT_EQ(second.success, first.success);
  EXPECT_EQ(second.steps, first.steps);
  EXPECT_EQ(second.decisions, first.decisions);
  EXPECT_EQ(trace(dir / "b.jsonl"), trace(dir / "a.jsonl"))
      << "the bus renders and estimates the same every run";

  // Replayed, the skills act again on the recorded estimates, each given when the recording took it in.
  const auto replayed = inproc::replay(dir / "a.jsonl", {paths::config_dir(), {}, std::nullopt, false, {}});
  EXPECT_TRUE(replayed.identical);
  EXPECT_EQ(replayed.actions_compared, first.steps) << "every action from a skill again";
  EXPECT_TRUE(replayed.recorded_only.empty());

  // From the last command's start: the governor and the host take the perceived world the snapshot holds,
  // perception looks afresh from there.
  const inproc::Recording rec = inproc::read_recording(dir / "a.jsonl");
  ASSERT_FALSE(rec.commands.empty());
  const std::uint32_t k = static_cast<std::uint32_t>(rec.commands.size() - 1);
  const sim::StateLog states = sim::read_state_log(fs::path(dir / "a.jsonl").replace_extension(".states"));
  const auto resumed =
      stack.resume({rec, states, task, k, std::nullopt, rec.commands[k].budget_steps}, dir / "r.jsonl");
  EXPECT_TRUE(resumed.success) << resumed.reason;
  EXPECT_GT(resumed.steps, rec.commands[k].start_step);

  // Evidence of a build before perceived worlds were recorded is refused with what is missing.
  inproc::Recording old = rec;
  old.commands[k].snapshot->state.erase("perceived_world");
  try {
    stack.resume({old, states, task, k, std::nullopt, rec.commands[k].budget_steps}, dir / "o.jsonl");
    FAIL() << "a snapshot without its perceived world resumed";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("holds no perceived world"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}
