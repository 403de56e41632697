// An episode on another arm, as `--robot ur7e` runs one: the UR7e on the scene's mount behind the same seam,
// skills and governor; its evidence names the robot, and it replays on that robot bit for bit.
#include <gtest/gtest.h>

#include <fstream>

#include <unistd.h>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/recording.hpp"
#include "dh/inproc/replay.hpp"
#include "dh/inproc/stack.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {
constexpr unsigned kTask = 1;  // goal 1, "put the bowl on the stove": a pick and place
}  // namespace

TEST(RobotEpisode, TheUr7eRunsAPickAndPlaceItsEvidenceNamesItAndItReplaysBitForBit) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("dh_robot_episode_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const auto suites = load_suites(paths::config_dir());
  inproc::Stack stack(paths::config_dir());
  stack.set_robot("ur7e");
  const TaskDef& task = find_task(suites, "goal", kTask);
  const auto out = stack.run(task, 21, "full", dir / "ep.jsonl");
  ASSERT_TRUE(out.success) << out.reason;

  const inproc::Recording rec = inproc::read_recording(dir / "ep.jsonl");
  EXPECT_EQ(rec.robot, "ur7e");
  const auto replayed = inproc::replay(dir / "ep.jsonl", {paths::config_dir(), {}, std::nullopt, false, {}});
  EXPECT_TRUE(replayed.identical);
  EXPECT_EQ(replayed.steps, out.steps);
  EXPECT_GT(replayed.actions_compared, 0u);

  stack.set_robot("kuka");
  try {
    stack.run(task, 21, "full", dir / "kuka.jsonl");
    FAIL() << "an unknown robot ran";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no robot 'kuka'"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}
