// Whole-plan checks of the rules slow brain on real scenes: every argument of every step, as the goal terms
// the plan brings about. Three sets of wordings: services/planner/tests/paraphrases.yaml (written for the
// tests by someone who never saw the parser, with wordings that must be refused), the -lan cells'
// rewordings (configs/suites/lan/wordings.yaml) and the benchmark cells' own instructions.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <iostream>
#include <map>
#include <memory>
#include <set>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/planner/rules.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

using namespace dh;
using namespace dh::planner;

namespace {

using Terms = std::set<std::string>;

std::string term(const std::string& predicate, const std::vector<std::string>& args) {
  return PredicateSpec{predicate, args}.text();
}

Terms terms(const std::vector<PredicateSpec>& goal) {
  Terms t;
  for (const auto& p : goal) t.insert(p.text());
  return t;
}

std::string text(const Terms& t) {
  std::string s;
  for (const auto& x : t) s += (s.empty() ? "" : " AND ") + x;
  return s.empty() ? "(none)" : s;
}

const EntityState& entity(const std::vector<EntityState>& scene, const std::string& name) {
  for (const auto& e : scene)
    if (e.name == name) return e;
  throw std::invalid_argument("the plan names '" + name + "', which is not in the scene");
}

std::string arg(const PlanStep& s, const std::string& role) {
  for (const auto& [r, v] : s.args)
    if (r == role) return v;
  throw std::invalid_argument(s.capability + " has no argument '" + role + "'");
}

// The region that is the inside of a drawer (Open/Close name a drawer by it, as the suites do).
std::string inside_of(const std::vector<EntityState>& scene, const std::string& part) {
  for (const auto& e : scene)
    if (e.kind == "region" && e.owner == part && e.relation == "in") return e.name;
  throw std::invalid_argument(part + " has no inside region");
}

// What a step's container is, for an opening step: the drawer itself or the door's fixture.
std::string opened_container(const std::vector<EntityState>& scene, const PlanStep& s) {
  if (s.capability == "slide_drawer") return arg(s, "drawer");
  return entity(scene, arg(s, "door")).owner;
}

// The goal terms a plan brings about, in the suites' vocabulary. An opening step whose container a later
// step puts something into is only a means (the suites' convention: "open the top drawer and put the bowl
// inside" has the goal In(bowl, cabinet_top_region) alone), so it contributes no term.
Terms plan_terms(const std::vector<PlanStep>& plan, const std::vector<EntityState>& scene) {
  Terms t;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    const PlanStep& s = plan[i];
    if (s.capability == "pick_place" || s.capability == "push") {
      const std::string target = arg(s, "target");
      const EntityState& r = entity(scene, target);
      t.insert(term(r.kind == "region" && r.relation == "in" ? "In" : "On", {arg(s, "object"), target}));
    } else if (s.capability == "slide_drawer" || s.capability == "swing_door") {
      const bool open = arg(s, "state") == "open";
      if (open) {
        const std::string container = opened_container(scene, s);
        const bool enabling = std::any_of(plan.begin() + i + 1, plan.end(), [&](const PlanStep& later) {
          if (later.capability != "pick_place" && later.capability != "push") return false;
          const EntityState& r = entity(scene, arg(later, "target"));
          return r.kind == "region" && r.owner == container;
        });
        if (enabling) continue;
      }
      const std::string what = s.capability == "slide_drawer" ? inside_of(scene, arg(s, "drawer"))
                                                               : entity(scene, arg(s, "door")).owner;
      t.insert(term(open ? "Open" : "Close", {what}));
    } else if (s.capability == "turn_knob") {
      t.insert(term(arg(s, "state") == "on" ? "TurnOn" : "TurnOff", {entity(scene, arg(s, "knob")).owner}));
    } else {
      t.insert(s.capability + "?");
    }
  }
  return t;
}

// Real scenes, each observed once after reset(1).
const std::vector<EntityState>& scene_of(const std::string& stem) {
  static std::map<std::string, std::vector<EntityState>> cache;
  auto& s = cache[stem];
  if (s.empty()) {
    sim::Workcell cell(sim::load_scene(paths::config_dir() / "scenes" / (stem + ".yaml")));
    cell.reset(1, {});
    s = cell.observe().entities;
  }
  return s;
}

struct Tally {
  int passed = 0, total = 0;
  std::vector<std::string> failures;
  void check(const std::string& what, const std::string& instruction, const std::vector<EntityState>& scene,
             const Terms& expected) {
    ++total;
    std::string got;
    try {
      const auto plan = plan_steps(instruction, scene);
      const Terms planned = plan_terms(plan, scene);
      if (planned == expected) {
        ++passed;
        return;
      }
      got = text(planned);
    } catch (const std::exception& e) {
      got = std::string("refused: ") + e.what();
    }
    failures.push_back(what + " '" + instruction + "'\n    expected " + text(expected) + "\n    planned  " + got);
  }
  std::string report(const std::string& title) const {
    std::string s = title + ": " + std::to_string(passed) + "/" + std::to_string(total) + " pass";
    for (const auto& f : failures) s += "\n  " + f;
    return s;
  }
};

YAML::Node paraphrases() {
  return YAML::LoadFile((paths::home() / "services/planner/tests/paraphrases.yaml").string());
}

std::vector<PredicateSpec> goal_of(const YAML::Node& entry) {
  std::vector<PredicateSpec> goal;
  for (const auto& g : entry["goal"])
    goal.push_back({g["predicate"].as<std::string>(), g["args"].as<std::vector<std::string>>()});
  return goal;
}

// A goal term the task's instruction does not state: LIBERO-10's task 8 ("put both moka pots on the stove")
// also requires TurnOn(stove), which the prompt leaves out (the stove starts on). The planner can only be
// asked for what the words say, so that term is left out of the comparison for the task's own wordings
// (long, long-swap, long-lan); long-task 8 states it ("... and turn it on") and keeps it.
Terms stated_goal(const TaskDef& task) {
  Terms t = terms(task.goal);
  if (task.base_suite == "long" && task.id == 8 && task.perturbation != "task") t.erase("TurnOn(stove)");
  return t;
}

std::vector<EntityState> task_scene(const TaskDef& task) {
  static std::map<std::string, std::vector<EntityState>> cache;
  auto& s = cache[sim::task_scene_key(task, 1)];
  if (s.empty()) {
    sim::Workcell cell(sim::load_task_scene(task, 1));
    cell.reset(1, task.goal);
    s = cell.observe().entities;
  }
  return s;
}

}  // namespace

TEST(RulesWholePlans, ParaphrasesPlanToTheirGoals) {
  const YAML::Node root = paraphrases();
  Tally tally;
  for (const auto& p : root["paraphrases"]) {
    const std::string scene = p["scene"].as<std::string>();
    tally.check(scene + ":", p["text"].as<std::string>(), scene_of(scene), terms(goal_of(p)));
  }
  std::cout << tally.report("paraphrases") << "\n";
  EXPECT_GE(tally.total, 100);
  EXPECT_EQ(tally.passed, tally.total) << tally.report("paraphrases");
}

TEST(RulesWholePlans, ParaphrasesThatMustBeRefusedAre) {
  const YAML::Node root = paraphrases();
  int refused = 0, total = 0;
  std::string failures;
  for (const auto& p : root["refuse"]) {
    const std::string scene = p["scene"].as<std::string>(), instruction = p["text"].as<std::string>();
    ++total;
    try {
      const auto plan = plan_steps(instruction, scene_of(scene));
      failures += "\n  " + scene + ": '" + instruction + "' planned " + text(plan_terms(plan, scene_of(scene))) +
                  " (must be refused: " + p["why"].as<std::string>() + ")";
    } catch (const std::invalid_argument& e) {
      ++refused;
      std::cout << "  refused '" << instruction << "': " << e.what() << "\n";
    }
  }
  std::cout << "refusals: " << refused << "/" << total << " refused" << failures << "\n";
  EXPECT_EQ(refused, total) << failures;
}

TEST(RulesWholePlans, LanguageCellWordingsPlanToTheirTasksGoals) {
  const auto suites = load_suites(paths::config_dir());
  Tally tally;
  for (const std::string cell : {"goal-lan", "long-lan"})
    for (const auto& [id, task] : suites.at(cell).tasks)
      for (const auto& wording : task.wordings)
        tally.check(cell + "[" + std::to_string(id) + "]", wording, task_scene(task), stated_goal(task));
  std::cout << tally.report("lan wordings") << "\n";
  EXPECT_EQ(tally.total, 120);
  EXPECT_EQ(tally.passed, tally.total) << tally.report("lan wordings");
}

TEST(RulesWholePlans, EveryBenchmarkInstructionPlansToItsGoal) {
  const auto suites = load_suites(paths::config_dir());
  Tally tally;
  std::set<std::string> distinct, distinct_failed;
  for (const auto& [name, suite] : suites) {
    if (suite.perturbation == "lan" || suite.perturbation == "pos" || suite.perturbation == "object")
      continue;  // the base cells' instructions
    for (const auto& [id, task] : suite.tasks) {
      const std::size_t before = tally.failures.size();
      tally.check(name + "[" + std::to_string(id) + "]", task.instruction, task_scene(task), stated_goal(task));
      distinct.insert(task.instruction);
      if (tally.failures.size() > before) distinct_failed.insert(task.instruction);
    }
  }
  std::cout << tally.report("benchmark instructions (cell x task)") << "\ndistinct benchmark instructions: "
            << distinct.size() - distinct_failed.size() << "/" << distinct.size() << " pass\n";
  EXPECT_EQ(tally.total, 72);  // goal, long and hw, each with -task and -swap
  EXPECT_EQ(distinct.size(), 48u);
  EXPECT_EQ(tally.passed, tally.total) << tally.report("benchmark instructions");
}
