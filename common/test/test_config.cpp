#include <gtest/gtest.h>

#include "config_files.hpp"  // tests/support
#include "dh/common/arms.hpp"
#include "dh/common/config.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"

using namespace dh;
using test::error_of;
using test::TempDir;

TEST(Config, MissingFileIsNamed) {
  const auto e = error_of([] { ConfigNode::load_file("/nonexistent/dh.yaml"); });
  EXPECT_NE(e.find("/nonexistent/dh.yaml"), std::string::npos);
  EXPECT_NE(e.find("not found"), std::string::npos);
}

TEST(Config, MalformedYamlNamesFileAndLine) {
  TempDir t;
  const auto f = t.write("bad.yaml", "a: 1\nb: [1, 2\n");
  const auto e = error_of([&] { ConfigNode::load_file(f); });
  EXPECT_NE(e.find("bad.yaml"), std::string::npos);
  EXPECT_NE(e.find("malformed YAML at line"), std::string::npos);
}

TEST(Config, MissingKeyAndWrongTypeNameTheKeyPathAndExpectedType) {
  const auto n = ConfigNode::load_string("robot:\n  base: [1, 2, x]\n  name: 3\n", "inline.yaml");
  auto e = error_of([&] { n.child("robot").get<std::string>("urdf"); });
  EXPECT_NE(e.find("inline.yaml: key 'robot.urdf': missing (expected a string)"), std::string::npos) << e;
  e = error_of([&] { n.child("robot").get<std::vector<double>>("base"); });
  EXPECT_NE(e.find("key 'robot.base': expected a list of numbers"), std::string::npos) << e;
  e = error_of([&] { ConfigNode::load_string("steps: -3", "s.yaml").get<unsigned>("steps"); });
  EXPECT_NE(e.find("key 'steps'"), std::string::npos) << e;
}

TEST(Suites, UnknownSuiteAndTaskListWhatExists) {
  const auto suites = load_suites(paths::config_dir());
  auto e = error_of([&] { find_task(suites, "spatial", 0); });
  EXPECT_NE(e.find("unknown suite 'spatial' (known: goal"), std::string::npos) << e;
  e = error_of([&] { find_task(suites, "goal", 42); });
  EXPECT_NE(e.find("suite 'goal' has no task 42"), std::string::npos) << e;
  EXPECT_EQ(find_task(suites, "goal", 8).instruction, "put the bowl on the plate");
}

TEST(Suites, ASuiteWithoutAGoalIsRejected) {
  TempDir t;
  t.write("scenes/s.yaml", "scene: s\n");
  t.write("suites/x.yaml", "suite: x\nbudget_steps: 10\nscene: s.yaml\ntasks:\n  - {id: 0, instruction: hi, goal: []}\n");
  const auto e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("x.yaml: key 'tasks[0].goal'"), std::string::npos) << e;
}

TEST(Suites, LanCellsRewordEveryTaskAndTheSeedPicksTheWording) {
  const auto suites = load_suites(paths::config_dir());
  for (const std::string base : {"goal", "long"}) {
    const SuiteDef& lan = suites.at(base + "-lan");
    const SuiteDef& plain = suites.at(base);
    ASSERT_EQ(lan.tasks.size(), plain.tasks.size());
    for (const auto& [id, t] : lan.tasks) {
      EXPECT_GE(t.wordings.size(), 6u) << base << " " << id;
      EXPECT_EQ(goal_text(t.goal), goal_text(plain.tasks.at(id).goal)) << "a rewording keeps the goal";
      EXPECT_EQ(t.suite, base + "-lan");
      for (const auto& w : t.wordings) EXPECT_NE(w, t.instruction) << "a wording differs from the instruction";
    }
  }
  const TaskDef& t = find_task(suites, "goal-lan", 8);
  EXPECT_EQ(instruction_for(t, 21), t.wordings[21 % t.wordings.size()]);
  EXPECT_EQ(instruction_for(find_task(suites, "goal", 8), 21), "put the bowl on the plate");
}

namespace {
/// Suite `x`: one task (0) in scene `s`, with its task and swap perturbations.
void write_one_task_suite(TempDir& t) {
  t.write("scenes/s.yaml", "scene: s\n");
  t.write("suites/x.yaml", "suite: x\nbudget_steps: 10\nscene: s.yaml\ntasks:\n  - {id: 0, instruction: hi, goal: "
                           "[{predicate: Open, args: [d]}], task: {instruction: ho, goal: [{predicate: Open, args: [e]}]}, "
                           "swap: {exchange: [[a, b]]}}\n");
}
}  // namespace

TEST(Suites, WordingsForAMissingTaskOrSuiteAreNamed) {
  TempDir t;
  write_one_task_suite(t);
  t.write("suites/lan/wordings.yaml", "suites:\n  x:\n    - {task: 3, wordings: [hey]}\n");
  auto e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("wordings.yaml: key 'suites.x[0].task': suite 'x' has no task 3"), std::string::npos) << e;
  t.write("suites/lan/wordings.yaml", "suites:\n  y:\n    - {task: 0, wordings: [hey]}\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("no suite 'y' in configs/suites to reword"), std::string::npos) << e;
  t.write("suites/lan/wordings.yaml", "suites:\n  x:\n    - {task: 0, wordings: [hey, there]}\n");
  EXPECT_EQ(instruction_for(find_task(load_suites(t.dir), "x-lan", 0), 3), "there");
}

TEST(Suites, PosCellsKeepEveryTaskAndTheSeedPicksTheMagnitude) {
  const auto suites = load_suites(paths::config_dir());
  for (const std::string base : {"goal", "long"}) {
    const SuiteDef& pos = suites.at(base + "-pos");
    const SuiteDef& plain = suites.at(base);
    ASSERT_EQ(pos.tasks.size(), plain.tasks.size());
    for (const auto& [id, t] : pos.tasks) {
      EXPECT_EQ(goal_text(t.goal), goal_text(plain.tasks.at(id).goal)) << "a displacement keeps the goal";
      EXPECT_EQ(t.instruction, plain.tasks.at(id).instruction);
      EXPECT_EQ(t.suite, base + "-pos");
      EXPECT_EQ(t.perturbation, "pos");
      EXPECT_EQ(t.pos.magnitudes, (std::vector<double>{0.1, 0.2, 0.3, 0.4, 0.5}));
    }
    EXPECT_TRUE(plain.tasks.at(0).pos.empty());
  }
  EXPECT_EQ(find_task(suites, "goal-pos", 3).pos.magnitude_for(23), 0.4);
}

TEST(Suites, ABadPositionsFileIsNamed) {
  TempDir t;
  write_one_task_suite(t);
  t.write("suites/pos/positions.yaml", "reach_m: 0.4\nmagnitudes: [0.1, 1.5]\nsuites: [x]\n");
  auto e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("positions.yaml: key 'magnitudes': each magnitude is in (0, 1]"), std::string::npos) << e;
  t.write("suites/pos/positions.yaml", "reach_m: 0.4\nmagnitudes: [0.1]\nsuites: [x-swap]\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("no unperturbed suite 'x-swap'"), std::string::npos) << e;
  t.write("suites/pos/positions.yaml", "magnitudes: [0.1]\nsuites: [x]\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("reach_m"), std::string::npos) << e;
  t.write("suites/pos/positions.yaml", "reach_m: 0.3\nmagnitudes: [0.1, 0.2]\nsuites: [x]\n");
  EXPECT_EQ(find_task(load_suites(t.dir), "x-pos", 0).pos.magnitude_for(3), 0.2);
}

TEST(Suites, ABadObjectsFileIsNamed) {
  TempDir t;
  write_one_task_suite(t);
  t.write("assets/bowl.yaml", "name: bowl\n");
  t.write("assets/bowl_deep.yaml", "name: bowl_deep\n");
  const std::string good = "height: [0.8, 1.2]\nmass: [0.6, 1.6]\nshade: 0.15\ninstance_share: 0.5\nsuites: [x]\n";
  t.write("suites/object/objects.yaml", "width: [1.2, 0.8]\n" + good + "instances: {bowl: [bowl_deep]}\n");
  auto e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("objects.yaml: key 'width': give [low, high] factors"), std::string::npos) << e;
  t.write("suites/object/objects.yaml", "width: [0.8, 1.2]\n" + good + "instances: {bowl: [bowl_huge]}\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("no asset 'bowl_huge'"), std::string::npos) << e;
  t.write("suites/object/objects.yaml", "width: [0.8, 1.2]\n" + good + "instances: {bowl: []}\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("list at least one other instance"), std::string::npos) << e;
  t.write("suites/object/objects.yaml", "width: [0.8, 1.2\n");
  e = error_of([&] { load_suites(t.dir); });
  EXPECT_NE(e.find("objects.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed YAML"), std::string::npos) << e;
  t.write("suites/object/objects.yaml", "width: [0.8, 1.2]\n" + good + "instances: {bowl: [bowl_deep]}\n");
  EXPECT_EQ(find_task(load_suites(t.dir), "x-object", 0).object.instances.at("bowl"),
            std::vector<std::string>{"bowl_deep"});
}

TEST(Evidence, AppendsFlushedRecordsAndSkipsATornLine) {
  TempDir t;
  const auto f = t.dir / "e.jsonl";
  {
    EvidenceWriter w(f);
    w.append("governor", "decision", {{"step", 10}});
    // A crash mid-write leaves a torn last line; readers keep every complete record.
    std::ofstream(f, std::ios::app) << "{\"kind\": \"decis";
  }
  const auto recs = read_evidence(f);
  ASSERT_EQ(recs.size(), 1u);
  EXPECT_EQ(recs[0]["kind"], "decision");
  EXPECT_EQ(recs[0]["step"], 10);
}

TEST(Arms, TheShippedArmsLoadAndBadOnesAreNamed) {
  const auto arms = load_arms(paths::config_dir() / "governor.yaml");
  for (const char* name : {"full", "full-perception", "static", "seq", "no-analytic", "no-recovery", "no-vla", "no-latch", "bare"})
    EXPECT_TRUE(arms.count(name)) << name;
  EXPECT_EQ(arms.at("static").mode, "static");
  EXPECT_EQ(arms.at("no-analytic").masked,
            (std::vector<std::string>{"pick_place", "push", "slide_drawer", "turn_knob", "swing_door"}));
  EXPECT_FALSE(arms.at("no-latch").latch);
  EXPECT_TRUE(arms.at("full").latch);
  EXPECT_EQ(arms.at("full").grounding, "state");
  EXPECT_EQ(arms.at("full-perception").grounding, "perception");
  auto e = error_of([&] { find_arm(arms, "wizard"); });
  EXPECT_NE(e.find("unknown arm 'wizard' (arms: bare, full, full-perception, no-analytic, no-latch, no-recovery, no-vla, seq, static"),
            std::string::npos) << e;
  TempDir t;
  const auto f = t.write("governor.yaml", "arms:\n  fast: {mode: reckless}\n");
  e = error_of([&] { load_arms(f); });
  EXPECT_NE(e.find("governor.yaml: key 'arms.fast.mode': expected full, static, seq or bare, got 'reckless'"), std::string::npos)
      << e;
  e = error_of([&] { load_arms(t.write("g3.yaml", "arms:\n  eyes: {mode: full, grounding: telepathy}\n")); });
  EXPECT_NE(e.find("key 'arms.eyes.grounding': expected state or perception, got 'telepathy'"), std::string::npos) << e;
  e = error_of([&] { load_arms(t.write("g2.yaml", "decision_period_steps: 10\n")); });
  EXPECT_NE(e.find("key 'arms'"), std::string::npos) << e;
}
