// The seam core on a real workcell, event by event with the time passed in: what it applies, what it holds
// and what it refuses. The sequences that stalled channels over DDS (docs/observation-stall.md) each have
// a test here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/scene.hpp"
#include "dh/common/build_info.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/worker_ports.hpp"
#include "dh/sim/workcell.hpp"

using namespace dh;
using namespace std::chrono_literals;
using sim::SeamClock;
using sim::SeamCore;

namespace {

const SeamClock::time_point t0{};

struct SeamCoreTest : ::testing::Test {
  static void SetUpTestSuite() {
    const auto suites = load_suites(paths::config_dir());
    const TaskDef& t = find_task(suites, "goal", 0);
    cell = new sim::Workcell(sim::load_task_scene(t, 1));
    goal = new std::vector<PredicateSpec>(t.goal);
  }
  static void TearDownTestSuite() {
    delete cell;
    delete goal;
  }
  void SetUp() override {
    cell->reset(21, *goal);
    const auto fx = seam.start(*cell, "ep", 300, "goal", t0);
    ASSERT_TRUE(fx.observation);
    EXPECT_EQ(fx.observation->step, 0u);
  }
  sim::SeamEffects lease(const std::string& command, std::uint32_t valid_until, SeamClock::time_point at,
                         bool revoked = false) {
    return seam.on_lease({"ep", command, valid_until, 200, revoked}, at);
  }
  sim::SeamEffects act(const std::string& command, std::uint32_t step, SeamClock::time_point at) {
    return seam.on_action({"ep", command, step, {0, 0, 0, 0, 0, 0, -1}}, at);
  }

  static sim::Workcell* cell;
  static std::vector<PredicateSpec>* goal;
  SeamCore seam{3, sim::SeamSettings{1000ms, 60000ms, 1000ms}};
};
sim::Workcell* SeamCoreTest::cell = nullptr;
std::vector<PredicateSpec>* SeamCoreTest::goal = nullptr;

bool refused(const sim::SeamEffects& fx, const std::string& command, SeamEventKind kind) {
  for (const auto& e : fx.events)
    if (e.command_id == command && e.kind == kind) return true;
  return false;
}

}  // namespace

TEST_F(SeamCoreTest, StartsWithTheObservationOfStepZeroStamped) {
  const Observation& o = seam.observation();
  EXPECT_EQ(o.channel, 3u);
  EXPECT_EQ(o.episode_id, "ep");
  EXPECT_EQ(o.budget_steps, 300u);
  EXPECT_TRUE(seam.running());
}

TEST_F(SeamCoreTest, AppliesALeasedActionAndGivesTheNextStep) {
  lease("c0", 10, t0);
  const auto fx = act("c0", 0, t0 + 50ms);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.observation->step, 1u);
  EXPECT_EQ(seam.step(), 1u);
  EXPECT_EQ(seam.held(), 0u);
}

// Observations go to whom they are for (dds_addressee.hpp): a step to the sender of the action that led to
// it; a command's start step again, once, when its first lease comes, for a capability that was not sent it.
TEST_F(SeamCoreTest, AStepIsForTheSenderOfItsActionAndACommandsStartIsSaidAgainAtItsFirstLease) {
  auto fx = lease("c0", 10, t0);
  ASSERT_TRUE(fx.again) << "c0 starts on step 0";
  EXPECT_EQ(fx.again->step, 0u);
  EXPECT_EQ(fx.again->episode_id, "ep");
  EXPECT_FALSE(fx.observation);
  EXPECT_FALSE(lease("c0", 12, t0 + 10ms).again) << "a rewritten lease starts nothing";

  fx = seam.on_action({"ep", "c0", 0, {0, 0, 0, 0, 0, 0, -1}, 0, "host-a"}, t0 + 20ms);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.to, "host-a");
  EXPECT_FALSE(fx.again);

  fx = lease("c1", 12, t0 + 30ms);
  ASSERT_TRUE(fx.again) << "c1 starts on step 1";
  EXPECT_EQ(fx.again->step, 1u);
  EXPECT_EQ(fx.again->ee_p, seam.observation().ee_p);
  fx = seam.on_action({"ep", "c1", 1, {0, 0, 0, 0, 0, 0, -1}, 0, "host-b"}, t0 + 40ms);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.to, "host-b");
}

// An action that overtook its command's first lease applies with that lease: the start is said again first.
TEST_F(SeamCoreTest, AnActionThatOvertookItsFirstLeaseComesAfterTheStartSaidAgain) {
  EXPECT_FALSE(seam.on_action({"ep", "c0", 0, {0, 0, 0, 0, 0, 0, -1}, 0, "host-a"}, t0).observation);
  const auto fx = lease("c0", 10, t0 + 5ms);
  ASSERT_TRUE(fx.again);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.again->step, 0u);
  EXPECT_EQ(fx.observation->step, 1u);
  EXPECT_EQ(fx.to, "host-a");
}

// Suspect 1: the lease topic's deadline fired while the lease was valid by step. The action used to be
// refused and nothing re-sent it; now it waits for the writer and goes when the writer is heard.
TEST_F(SeamCoreTest, ASilentLeaseWriterHoldsAStepValidActionUntilItIsHeardAgain) {
  lease("c0", 10, t0);
  EXPECT_FALSE(seam.on_lease_silent(t0 + 500ms)) << "its own lease is younger than the deadline";
  EXPECT_TRUE(seam.on_lease_silent(t0 + 1100ms));
  auto fx = act("c0", 0, t0 + 1200ms);
  EXPECT_FALSE(fx.observation);
  EXPECT_TRUE(fx.events.empty()) << fx.events.front().reason;
  fx = seam.on_tick(t0 + 5s);  // far past the grace: still held, not refused
  EXPECT_FALSE(fx.observation);
  EXPECT_TRUE(fx.events.empty());
  fx = lease("c0", 10, t0 + 5100ms);  // the governor's lease written again
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.observation->step, 1u);
}

// Suspect 2: the action of a decision step reaches the seam before the renewal of its lease, and the
// renewal comes later than the grace period.
TEST_F(SeamCoreTest, AnActionPastItsLeaseWaitsForTheRenewalHoweverLate) {
  lease("c0", 1, t0);
  ASSERT_TRUE(act("c0", 0, t0).observation);
  auto fx = act("c0", 1, t0 + 50ms);
  EXPECT_FALSE(fx.observation);
  EXPECT_TRUE(fx.events.empty());
  fx = seam.on_tick(t0 + 3s);
  EXPECT_FALSE(fx.observation);
  EXPECT_TRUE(fx.events.empty());
  fx = lease("c0", 11, t0 + 3s);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.observation->step, 2u);
}

// Suspect 3: at a switch, the new command's first action arrives before its lease, then the old command's
// late action for the same step. It used to take the single pending slot; now each command waits in its own.
TEST_F(SeamCoreTest, AnOldCommandsLateActionDoesNotDisplaceTheNewOnes) {
  lease("c0", 10, t0);
  ASSERT_TRUE(act("c0", 0, t0).observation);
  lease("c0", 1, t0 + 60ms, true);  // the governor revokes c0 ...
  auto fx = act("c1", 1, t0 + 70ms);  // ... c1 answers step 1 before c1's lease is in
  EXPECT_FALSE(fx.observation);
  fx = act("c0", 1, t0 + 80ms);  // c0's late answer to the same step: a straggler, dropped
  EXPECT_TRUE(fx.events.empty());
  EXPECT_FALSE(fx.observation);
  fx = lease("c1", 11, t0 + 90ms);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.observation->step, 2u);
  EXPECT_EQ(seam.held(), 0u);
  EXPECT_EQ(seam.stragglers(), 1u);
}

// At a switch the old command's host may answer the step before it hears of the switch. Whether its
// answer comes before the revocation, between it and the new lease, or after the new command's action
// applied is a race between DDS topics: in every order the step goes the same way and nothing is recorded
// (in process the answer never comes), so the evidence over DDS is the one in process.
TEST_F(SeamCoreTest, AnOldCommandsAnswerAtASwitchLeavesTheSameRecordInEveryOrder) {
  for (int order = 0; order < 3; ++order) {
    seam.end();
    cell->reset(21, *goal);
    seam.start(*cell, "ep", 300, "goal", t0);
    lease("c0", 1, t0);  // step 1 is a decision step: the lease ends there
    ASSERT_TRUE(act("c0", 0, t0).observation);
    std::vector<SeamEvent> events;
    auto keep = [&](const sim::SeamEffects& fx) { events.insert(events.end(), fx.events.begin(), fx.events.end()); };
    if (order == 0) keep(act("c0", 1, t0 + 50ms));  // before the revocation: held, its lease ends at 1
    lease("c0", 1, t0 + 60ms, true);
    if (order == 1) keep(act("c0", 1, t0 + 65ms));  // between the revocation and the new lease
    keep(lease("c1", 11, t0 + 70ms));
    const auto fx = act("c1", 1, t0 + 80ms);
    keep(fx);
    ASSERT_TRUE(fx.observation) << "order " << order;
    if (order == 2) keep(act("c0", 1, t0 + 90ms));  // after c1's action applied
    EXPECT_TRUE(events.empty()) << "order " << order << ": " << events.front().reason;
    EXPECT_EQ(seam.step(), 2u);
    EXPECT_EQ(seam.held(), 0u);
    EXPECT_EQ(seam.stragglers(), 1u) << "order " << order;
  }
}

TEST_F(SeamCoreTest, AnActionOfACommandNeverLeasedIsRefusedAfterTheGrace) {
  lease("c0", 10, t0);
  EXPECT_FALSE(act("other", 0, t0).observation);
  EXPECT_TRUE(seam.on_tick(t0 + 900ms).events.empty());
  const auto fx = seam.on_tick(t0 + 1000ms);
  EXPECT_TRUE(refused(fx, "other", SeamEventKind::RejectedCommand));
  EXPECT_EQ(seam.held(), 0u);
  EXPECT_EQ(seam.step(), 0u);
}

TEST_F(SeamCoreTest, ARevokedCommandsActionsNeverApply) {
  lease("c0", 10, t0, true);
  const auto fx = act("c0", 0, t0);
  EXPECT_FALSE(fx.observation);
  EXPECT_EQ(seam.held(), 0u);
  EXPECT_EQ(seam.stragglers(), 1u);
  EXPECT_TRUE(seam.on_tick(t0 + 2s).events.empty());
  EXPECT_EQ(seam.step(), 0u);
}

TEST_F(SeamCoreTest, StaleFutureAndForeignActionsAreRefusedWithReasons) {
  lease("c0", 10, t0);
  ASSERT_TRUE(act("c0", 0, t0).observation);
  auto fx = act("c0", 0, t0 + 10ms);
  ASSERT_TRUE(refused(fx, "c0", SeamEventKind::RejectedStep));
  EXPECT_NE(fx.events.front().reason.find("channel is at step 1"), std::string::npos);
  EXPECT_TRUE(refused(act("c0", 5, t0 + 20ms), "c0", SeamEventKind::RejectedStep));
  fx = seam.on_action({"another-episode", "c0", 1, {}}, t0 + 30ms);
  ASSERT_TRUE(refused(fx, "c0", SeamEventKind::RejectedCommand));
  EXPECT_NE(fx.events.front().reason.find("another-episode"), std::string::npos);
  EXPECT_EQ(fx.events.front().episode_id, "another-episode") << "recorded for the episode it named, not this one";
  EXPECT_EQ(seam.step(), 1u);
}

TEST_F(SeamCoreTest, AResentActionForTheSameStepReplacesTheHeldOne) {
  lease("c0", 0, t0);  // expired by step: held
  EXPECT_FALSE(act("c0", 0, t0).observation);
  const auto fx = act("c0", 0, t0 + 100ms);
  EXPECT_TRUE(fx.events.empty());
  EXPECT_EQ(seam.held(), 1u);
}

TEST_F(SeamCoreTest, TheEpisodeBudgetEndsAdmission) {
  seam.end();
  cell->reset(21, *goal);
  seam.start(*cell, "ep", 1, "goal", t0);
  lease("c0", 10, t0);
  ASSERT_TRUE(act("c0", 0, t0).observation);
  EXPECT_TRUE(refused(act("c0", 1, t0 + 50ms), "c0", SeamEventKind::RejectedBudget));
}

TEST_F(SeamCoreTest, NothingForTheAbandonPeriodAbandonsTheEpisode) {
  lease("c0", 10, t0);
  EXPECT_FALSE(seam.on_tick(t0 + 59s).ended);
  const auto fx = seam.on_tick(t0 + 60s);
  ASSERT_TRUE(fx.ended);
  EXPECT_NE(fx.ended->find("abandoned at step 0"), std::string::npos);
  ASSERT_EQ(fx.events.size(), 1u);
  EXPECT_EQ(fx.events[0].kind, SeamEventKind::Ended) << "the governor hears it as a code";
  EXPECT_EQ(fx.events[0].reason, *fx.ended);
  EXPECT_FALSE(seam.running());
  EXPECT_EQ(seam.episode_id(), "ep") << "the last episode is still named";
  EXPECT_TRUE(refused(act("c0", 0, t0 + 61s), "c0", SeamEventKind::RejectedCommand));
}

/// The workcell, until its step `fail_at`: there it throws as MuJoCo's overflowing contact buffer or a
/// controller that stopped the arm does.
class FailingCell : public sim::SeamCell {
 public:
  FailingCell(sim::SeamCell& inner, int fail_at) : inner_(inner), left_(fail_at) {}
  std::vector<sim::StepEvent> step(const std::array<double, 7>& action) override {
    if (left_-- == 0) throw std::runtime_error("the controller reports protective stop");
    return inner_.step(action);
  }
  Observation observe() const override { return inner_.observe(); }

 private:
  sim::SeamCell& inner_;
  int left_;
};

TEST_F(SeamCoreTest, ACellThatCannotGoOnEndsTheEpisodeWithItsReasonAsAnEvent) {
  FailingCell failing(*cell, 2);
  cell->reset(21, *goal);
  seam.start(failing, "ep", 300, "goal", t0);
  lease("c0", 10, t0);
  ASSERT_TRUE(act("c0", 0, t0).observation);
  ASSERT_TRUE(act("c0", 1, t0 + 50ms).observation);
  const auto fx = act("c0", 2, t0 + 100ms);
  EXPECT_FALSE(fx.observation);
  ASSERT_TRUE(fx.ended);
  EXPECT_EQ(*fx.ended, "the cell failed at step 2: the controller reports protective stop");
  ASSERT_EQ(fx.events.size(), 1u);
  EXPECT_EQ(fx.events[0].kind, SeamEventKind::Ended);
  EXPECT_EQ(fx.events[0].command_id, "c0") << "the command whose action the cell could not apply";
  EXPECT_EQ(fx.events[0].step, 2u);
  EXPECT_EQ(fx.events[0].reason, *fx.ended);
  EXPECT_FALSE(seam.running());
}

TEST(WorkerPorts, MatchTheServiceReadme) {
  const char* home = std::getenv("DH_HOME");
  ASSERT_TRUE(home) << "DH_HOME names the checkout";
  EXPECT_EQ(port_table(std::filesystem::path(home) / "services/sim_worker/README.md"), port_table(sim::worker_ports()));
}

// The step log the seam writes beside the evidence: one record per step, read back as written, and a
// digest that tells the same state from a different one.
TEST_F(SeamCoreTest, WritesAStepLogThatReadsBackAsWritten) {
  const auto file = std::filesystem::path(::testing::TempDir()) / "seam_core_test.steps";
  seam.end();
  cell->reset(21, *goal);
  const sim::StateDigest reset = cell->digest();
  seam.start(*cell, "ep", 300, "goal", t0, file);
  lease("c0", 10, t0);
  ASSERT_TRUE(seam.on_action({"ep", "c0", 0, {0.5, 0, 0, 0, 0, 0, 1}}, t0).observation);
  ASSERT_TRUE(seam.on_action({"ep", "c0", 1, {0, 0.5, 0, 0, 0, 0, 1}, 7}, t0).observation);
  const sim::StateDigest after = cell->digest();
  seam.end();

  const sim::StepLog log = sim::read_step_log(file);
  EXPECT_EQ(log.header.model_hash, cell->model_hash());
  EXPECT_EQ(log.header.joints * 2, reset.joints.size());
  ASSERT_EQ(log.records.size(), 3u);
  EXPECT_EQ(log.records[0].step, 0u);
  EXPECT_EQ(log.records[0].command_id, "");
  EXPECT_EQ(log.records[0].digest, reset);
  EXPECT_EQ(log.records[2].command_id, "c0");
  EXPECT_EQ(log.records[2].action[1], 0.5);
  EXPECT_EQ(log.records[2].frames, 7u) << "the estimates the action's capability had taken in";
  EXPECT_EQ(log.records[2].digest, after);
  EXPECT_NE(reset.state, after.state);
  EXPECT_NE(reset.joints, after.joints);
  EXPECT_EQ(log.header.build, build_info().str());

  // A step log written before its records held the frames (DHSTEPS2), and before the header named the
  // build (DHSTEPS1), reads the same, with no frames and no build.
  {
    std::ifstream in(file, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t at = 8 + 8 + 4 + 4;  // magic, model hash, MuJoCo version, joints
    // Each record: step, state hash, the joints' hashes, aux, the action, then the frames this drops.
    std::size_t r = at + 2 + build_info().str().size();
    for (const auto& rec : log.records) {
      r += 4 + 8 + 4 * rec.digest.joints.size() + 16 + 56;
      bytes.erase(r, 4);
      r += 2 + rec.command_id.size();
    }
    bytes[7] = '2';
    const auto v2 = file.parent_path() / "seam_core_test_v2.steps";
    std::ofstream(v2, std::ios::binary) << bytes;
    const sim::StepLog older = sim::read_step_log(v2);
    ASSERT_EQ(older.records.size(), 3u);
    EXPECT_EQ(older.records[2].frames, 0u);
    EXPECT_EQ(older.records[2].digest, after);
    EXPECT_EQ(older.header.build, build_info().str());
    bytes[7] = '1';
    bytes.erase(at, 2 + build_info().str().size());
    const auto v1 = file.parent_path() / "seam_core_test_v1.steps";
    std::ofstream(v1, std::ios::binary) << bytes;
    const sim::StepLog old = sim::read_step_log(v1);
    EXPECT_EQ(old.header.build, "");
    EXPECT_EQ(old.header.model_hash, log.header.model_hash);
    ASSERT_EQ(old.records.size(), 3u);
    EXPECT_EQ(old.records[2].digest, after);
  }

  // A torn last record is dropped; a file that is not a step log is named.
  std::filesystem::resize_file(file, std::filesystem::file_size(file) - 3);
  EXPECT_EQ(sim::read_step_log(file).records.size(), 2u);
  std::ofstream(file) << "not a step log";
  try {
    sim::read_step_log(file);
    FAIL() << "read a file that is not a step log";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("seam_core_test.steps"), std::string::npos) << e.what();
  }
}

// The state log: the full physics state at step 0 and at each command's first lease (not at its
// renewals), read back as written; resuming from a command's state and applying the same actions gives
// the same states, bit for bit, as the run that recorded it.
TEST_F(SeamCoreTest, RecordsCommandStartStatesThatResumeBitIdentically) {
  const auto file = std::filesystem::path(::testing::TempDir()) / "seam_core_states.steps";
  seam.end();
  cell->reset(21, *goal);
  seam.start(*cell, "ep", 300, "goal", t0, file);
  const std::vector<std::array<double, 7>> actions{
      {0.5, 0, -0.3, 0, 0, 0.2, 1}, {0, 0.5, 0, 0.1, 0, 0, 1}, {0, 0, -0.8, 0, 0, 0, -1}, {0.3, -0.2, 0.4, 0, 0.3, 0, -1}};
  lease("c0", 2, t0);
  ASSERT_TRUE(seam.on_action({"ep", "c0", 0, actions[0]}, t0).observation);
  lease("c0", 10, t0);  // a renewal: no new record
  ASSERT_TRUE(seam.on_action({"ep", "c0", 1, actions[1]}, t0).observation);
  lease("c1", 10, t0);
  const sim::PhysicsState at_c1 = cell->physics_state();
  const sim::StateDigest digest_c1 = cell->digest();
  std::vector<sim::StateDigest> recorded;
  for (std::uint32_t k = 2; k < 4; ++k) {
    ASSERT_TRUE(seam.on_action({"ep", "c1", k, actions[k]}, t0).observation);
    recorded.push_back(cell->digest());
  }
  seam.end();

  const sim::StateLog log = sim::read_state_log(std::filesystem::path(file).replace_extension(".states"));
  EXPECT_EQ(log.header.model_hash, cell->model_hash());
  EXPECT_EQ(log.header.shape, cell->shape());
  ASSERT_EQ(log.records.size(), 3u);
  EXPECT_EQ(log.records[0].step, 0u);
  EXPECT_EQ(log.records[0].command_id, "");
  EXPECT_EQ(log.records[1].command_id, "c0");
  EXPECT_EQ(log.records[1].step, 0u);
  const sim::StateRecord* c1 = log.for_command("c1");
  ASSERT_NE(c1, nullptr);
  EXPECT_EQ(c1->step, 2u);
  EXPECT_EQ(c1->state, at_c1);

  // A fresh reset with another seed, then the recorded state: the same steps follow.
  cell->reset(22, *goal);
  sim::SeamCore again{3, sim::SeamSettings{1000ms, 60000ms, 1000ms}};
  const auto fx = again.resume(*cell, "ep2", 300, "goal", *c1, t0);
  ASSERT_TRUE(fx.observation);
  EXPECT_EQ(fx.observation->step, 2u);
  EXPECT_EQ(cell->digest(), digest_c1);
  EXPECT_EQ(cell->physics_state(), at_c1);
  again.on_lease({"ep2", "c1", 10, 200, false}, t0);
  for (std::uint32_t k = 2; k < 4; ++k) {
    ASSERT_TRUE(again.on_action({"ep2", "c1", k, actions[k]}, t0).observation);
    EXPECT_EQ(cell->digest(), recorded[k - 2]) << "step " << k + 1;
  }
  again.end();

  // A state of another model is refused by name; a torn last record is dropped.
  sim::PhysicsState wrong = at_c1;
  wrong.qpos.pop_back();
  EXPECT_THROW(cell->restore(wrong), std::invalid_argument);
  const auto states = std::filesystem::path(file).replace_extension(".states");
  std::filesystem::resize_file(states, std::filesystem::file_size(states) - 5);
  EXPECT_EQ(sim::read_state_log(states).records.size(), 2u);
}

// Applied forces are stored sparse; a -0.0 among them comes back as -0.0, and states compare bit for bit.
TEST_F(SeamCoreTest, AStateReadsBackBitForBit) {
  const auto file = std::filesystem::path(::testing::TempDir()) / "seam_core_bits.states";
  sim::PhysicsState s = cell->physics_state();
  s.xfrc_applied[6] = -0.0;
  s.qfrc_applied[0] = 1.5;
  sim::PhysicsState zero = s;
  zero.xfrc_applied[6] = 0.0;
  EXPECT_FALSE(s == zero) << "-0.0 and 0.0 are other bits";
  {
    sim::StateLogWriter w(file, {cell->model_hash(), 0, cell->shape()});
    w.append({5, "c9", s});
  }
  const auto log = sim::read_state_log(file);
  ASSERT_EQ(log.records.size(), 1u);
  EXPECT_TRUE(log.records[0].state == s);
  EXPECT_TRUE(std::signbit(log.records[0].state.xfrc_applied[6]));
}
