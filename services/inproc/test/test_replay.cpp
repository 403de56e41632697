// Replay of an episode recorded in process: identical when nothing changed, the first divergence named
// when the record is altered, refused when θ in the library differs, clear errors for missing files.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include <unistd.h>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/replay.hpp"
#include "dh/inproc/stack.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {

// Figure 3's case: push refused at its check, pick and place substituted (two commands).
struct Replay : ::testing::Test {
  static void SetUpTestSuite() {
    // One folder per process: ctest runs each test of this suite as a process of its own, side by side.
    dir = new fs::path(fs::path(::testing::TempDir()) / ("dh_replay_test_" + std::to_string(getpid())));
    fs::remove_all(*dir);
    inproc::Stack stack(paths::config_dir());
    const auto suites = load_suites(paths::config_dir());
    outcome = new inproc::EpisodeOutcome(
        stack.run(find_task(suites, "goal-swap", 5), 21, "full", *dir / "ep.jsonl"));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir);
    delete outcome;
    delete dir;
  }
  static inproc::ReplayOptions options() { return {paths::config_dir(), {}, std::nullopt, false, {}}; }
  /// A copy of the recording to alter.
  static fs::path copy(const std::string& name) {
    fs::copy_file(*dir / "ep.jsonl", *dir / (name + ".jsonl"), fs::copy_options::overwrite_existing);
    for (const char* ext : {".steps", ".states"})
      fs::copy_file(*dir / ("ep" + std::string(ext)), *dir / (name + ext), fs::copy_options::overwrite_existing);
    return *dir / (name + ".jsonl");
  }
  static fs::path* dir;
  static inproc::EpisodeOutcome* outcome;
};
fs::path* Replay::dir = nullptr;
inproc::EpisodeOutcome* Replay::outcome = nullptr;

}  // namespace

TEST_F(Replay, AnUnchangedRecordingReplaysBitForBit) {
  ASSERT_TRUE(outcome->success) << outcome->reason;
  const auto r = inproc::replay(*dir / "ep.jsonl", options());
  EXPECT_TRUE(r.identical);
  EXPECT_EQ(r.steps, outcome->steps);
  EXPECT_EQ(r.recorded_steps, outcome->steps);
  EXPECT_EQ(r.actions_compared, outcome->steps) << "every action came from a skill given again";
  EXPECT_FALSE(r.first_divergence);
  EXPECT_TRUE(r.verdicts_identical);
  EXPECT_EQ(r.states_checked, 3u) << "step 0 and the two commands' starts, each compared whole";
  const auto j = inproc::to_json(r);
  EXPECT_TRUE(j["identical"].get<bool>());
  EXPECT_TRUE(j["first_divergence"].is_null());
}

TEST_F(Replay, FromACommandComparesOnlyThatCommandsActions) {
  auto o = options();
  o.from_command = 1;  // pick_place after the refused push, from the state recorded at its start
  const auto r = inproc::replay(*dir / "ep.jsonl", o);
  EXPECT_TRUE(r.identical);
  EXPECT_EQ(r.actions_compared, r.steps - r.from_step) << "every step from the restored one is pick_place's";
  EXPECT_EQ(r.steps, outcome->steps);
  o.from_command = 0;  // the push, refused at its check: no action, its state alone
  const auto refused = inproc::replay(*dir / "ep.jsonl", o);
  EXPECT_TRUE(refused.identical);
  EXPECT_EQ(refused.actions_compared, 0u);
  EXPECT_EQ(refused.states_checked, 0u) << "the restored state is the record: nothing else recorded is reached";
  o.from_command = 7;
  EXPECT_THROW(inproc::replay(*dir / "ep.jsonl", o), std::invalid_argument);
}

TEST_F(Replay, AnAlteredActionIsTheFirstDivergenceWithItsBodyAndQuantity) {
  const fs::path ev = copy("altered");
  // Record 40's gripper component: header 8 + 8 + 4 + 4 bytes and the build string, then fixed-size
  // records up to the id.
  sim::StepLog log = sim::read_step_log(*dir / "altered.steps");
  ASSERT_GT(log.records.size(), 41u);
  std::fstream f(*dir / "altered.steps", std::ios::in | std::ios::out | std::ios::binary);
  std::size_t at = 24 + 2 + log.header.build.size();
  const std::size_t fixed = 4 + 8 + 4 * log.records[0].digest.joints.size() + 16 + 56 + 4 + 2;
  for (std::size_t i = 0; i < 40; ++i) at += fixed + log.records[i].command_id.size();
  const double changed = log.records[40].action[2] + 0.25;
  f.seekp(static_cast<std::streamoff>(at + 4 + 8 + 4 * log.records[0].digest.joints.size() + 16 + 2 * 8));
  f.write(reinterpret_cast<const char*>(&changed), sizeof changed);
  f.close();
  ASSERT_EQ(sim::read_step_log(*dir / "altered.steps").records[40].action[2], changed);

  const auto r = inproc::replay(ev, options());
  EXPECT_FALSE(r.identical);
  ASSERT_TRUE(r.first_divergence);
  EXPECT_EQ(r.first_divergence->step, 39u) << "the skill's own action for step 39 is not the recorded one";
  EXPECT_EQ(r.first_divergence->quantity, "action[2]");
  EXPECT_EQ(r.first_divergence->body, "pick_place");
  EXPECT_GT(r.divergent_steps, 1u) << "the states after it differ too";
}

TEST_F(Replay, AChangedThetaInTheLibraryRefusesTheReplayUnlessDriftIsAllowed) {
  const fs::path library = *dir / "library";
  fs::remove_all(library);
  fs::copy(paths::config_dir() / "library", library);
  std::ifstream in(library / "pick_place.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const auto at = text.find("approach_height:");
  ASSERT_NE(at, std::string::npos) << "configs/library/pick_place.yaml has no approach_height";
  const auto end = text.find('\n', at);
  text.replace(at, end - at, "approach_height: 0.1134");
  std::ofstream(library / "pick_place.yaml") << text;

  auto o = options();
  o.library_dir = library;
  try {
    inproc::replay(*dir / "ep.jsonl", o);
    FAIL() << "a changed θ was replayed without a word";
  } catch (const inproc::FingerprintMismatch& e) {
    EXPECT_NE(std::string(e.what()).find("pick_place θ approach_height"), std::string::npos) << e.what();
  }
  o.allow_drift = true;
  const auto r = inproc::replay(*dir / "ep.jsonl", o);
  ASSERT_EQ(r.drift.size(), 1u);
  EXPECT_NE(r.drift[0].find("0.1134"), std::string::npos) << r.drift[0];
  EXPECT_TRUE(r.identical) << "the recorded θ is what the commands run with";
}

TEST_F(Replay, MissingOrCorruptFilesAreNamed) {
  const auto message = [](const fs::path& p) {
    try {
      inproc::replay(p, options());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(*dir / "nothing.jsonl").find("nothing.jsonl"), std::string::npos);
  const fs::path no_steps = copy("no_steps");
  fs::remove(*dir / "no_steps.steps");
  EXPECT_NE(message(no_steps).find("no_steps.steps"), std::string::npos);
  // Without its state log a recording replays from its step log; starting from a command needs it.
  const fs::path no_states = copy("no_states");
  fs::remove(*dir / "no_states.states");
  const auto full = inproc::replay(no_states, options());
  EXPECT_TRUE(full.identical);
  EXPECT_EQ(full.states_checked, 0u);
  auto from = options();
  from.from_command = 1;
  try {
    inproc::replay(no_states, from);
    FAIL() << "started from a command without its recorded state";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no_states.states"), std::string::npos) << e.what();
  }
  const fs::path torn = copy("torn");
  std::ofstream(*dir / "torn.jsonl") << "{\"kind\": \"plan_request\"}\n";
  EXPECT_NE(message(torn).find("no episode_request"), std::string::npos);
}

// From a state recorded mid-episode, with an object in the hand (long-task 0, seed 21: the second command
// starts at step 159 carrying the ketchup). MuJoCo's forward pass renormalises a free joint's quaternion
// in place, and not idempotently in the last bit: a state taken after it would restore with the carried
// object moved by one ulp, and the command's replay would diverge at once.
TEST(ReplayMidEpisode, AStateRecordedWhileCarryingRestoresBitForBit) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("dh_replay_mid_" + std::to_string(getpid()));
  fs::remove_all(dir);
  inproc::Stack stack(paths::config_dir());
  const auto out = stack.run(find_task(load_suites(paths::config_dir()), "long-task", 0), 21, "full", dir / "ep.jsonl");
  ASSERT_TRUE(out.success) << out.reason;
  inproc::ReplayOptions o{paths::config_dir(), {}, 1u, false, {}};
  const auto r = inproc::replay(dir / "ep.jsonl", o);
  EXPECT_GT(r.from_step, 100u) << "the second command starts mid-episode";
  EXPECT_TRUE(r.identical) << (r.first_divergence ? r.first_divergence->body + " " + r.first_divergence->quantity : "");
  EXPECT_EQ(r.actions_compared, r.steps - r.from_step);
  fs::remove_all(dir);
}

// long-swap 3, seed 21: the bowl's pick and place runs 320 steps, past the 274 its cost model's budget
// gives, on the budget the governor raised for its plan. The replay gives the host those raises as the
// governor did, and the command runs to its end again.
TEST(ReplayRaisedBudget, ACommandPastItsFirstBudgetReplaysBitForBit) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("dh_replay_raised_" + std::to_string(getpid()));
  fs::remove_all(dir);
  inproc::Stack stack(paths::config_dir());
  stack.run(find_task(load_suites(paths::config_dir()), "long-swap", 3), 21, "full", dir / "ep.jsonl");
  const inproc::Recording rec = inproc::read_recording(dir / "ep.jsonl");
  ASSERT_FALSE(rec.commands.empty());
  const inproc::RecordedCommand& first = rec.commands.front();
  ASSERT_FALSE(first.budget_raises.empty());
  ASSERT_TRUE(first.end);
  EXPECT_EQ(first.end->state, "completed");
  EXPECT_GT(first.end->steps_used, first.budget_steps) << "it ran past the budget it was dispatched with";
  const auto r = inproc::replay(dir / "ep.jsonl", {paths::config_dir(), {}, std::nullopt, false, {}});
  EXPECT_TRUE(r.identical) << (r.first_divergence
                                   ? std::to_string(r.first_divergence->step) + " " +
                                         r.first_divergence->body + " " + r.first_divergence->quantity
                                   : "");
  fs::remove_all(dir);
}

TEST_F(Replay, AnotherBuildOrInstructionIsAFingerprintDifference) {
  const fs::path ev = copy("other_build");
  std::ifstream in(ev);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const std::string build = "\"build\":\"";
  const auto at = text.find(build);
  ASSERT_NE(at, std::string::npos) << "the request records the build";
  text.insert(at + build.size(), "0000");
  const std::string instruction = "\"instruction\":\"";
  const auto i = text.find(instruction);
  ASSERT_NE(i, std::string::npos);
  text.insert(i + instruction.size(), "please ");
  std::ofstream(ev) << text;
  try {
    inproc::replay(ev, options());
    FAIL() << "another build's recording replayed without a word";
  } catch (const inproc::FingerprintMismatch& e) {
    EXPECT_NE(std::string(e.what()).find("recorded by build 0000"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the recording's instruction was \"please "), std::string::npos) << e.what();
  }
}
