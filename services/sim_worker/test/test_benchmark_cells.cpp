// The benchmark's cells: eight cells of ten tasks each (and the -lan, -pos and -object ones), every cell x
// task instantiating for seeds 1-60 with objects at rest, nothing interpenetrating, the goal not already
// met, and the same state for the same seed; -pos cells within their magnitudes, -object cells within
// their bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

constexpr unsigned kSeeds = 60;
// After the 0.4 s settle of reset(): objects slower than this are at rest (m/s).
constexpr double kAtRest = 0.005;
// Deepest overlap accepted between touching bodies (MuJoCo's soft contacts rest ~0.1 mm deep).
constexpr double kMaxPenetration = 0.002;
// Seeds reset a second time to check the state is reproduced bit for bit.
constexpr unsigned kRepeatSeeds = 10;

const std::map<std::string, SuiteDef>& suites() {
  static const auto s = load_suites(paths::config_dir());
  return s;
}

TEST(BenchmarkCells, EightCellsOfTenTasksWithTheirPerturbations) {
  for (const char* name : {"goal", "goal-task", "goal-swap", "long", "long-task", "long-swap", "goal-pos", "long-pos"}) {
    ASSERT_TRUE(suites().count(name)) << name;
    EXPECT_EQ(suites().at(name).tasks.size(), 10u) << name;
  }
  for (const char* base : {"goal", "long"})
    for (const auto& [id, t] : suites().at(base).tasks) {
      const TaskDef& redirected = suites().at(std::string(base) + "-task").tasks.at(id);
      const TaskDef& swapped = suites().at(std::string(base) + "-swap").tasks.at(id);
      EXPECT_NE(redirected.instruction, t.instruction) << base << "/" << id;
      EXPECT_NE(redirected.goal.front().text() + redirected.goal.back().text(),
                t.goal.front().text() + t.goal.back().text()) << base << "/" << id;
      EXPECT_EQ(redirected.scene_file, t.scene_file);
      EXPECT_TRUE(redirected.swap.empty());
      EXPECT_EQ(swapped.instruction, t.instruction);
      EXPECT_FALSE(swapped.swap.empty()) << base << "/" << id;
      EXPECT_EQ(t.budget_steps, std::string(base) == "goal" ? 300u : 520u);
    }
  for (const auto& [id, t] : suites().at("long").tasks) EXPECT_GE(t.goal.size(), id == 5 ? 1u : 2u) << id;
}

// One model per scene key, as the simulator worker caches them (object cells, whose model is the seed's,
// have their own test).
TEST(BenchmarkCells, EveryCellAndTaskInstantiatesForSeeds1To60) {
  std::map<std::string, std::vector<const TaskDef*>> by_scene;
  for (const auto& [cell, suite] : suites())
    for (const auto& [id, task] : suite.tasks)
      if (task.object.empty()) by_scene[sim::task_scene_key(task, 0)].push_back(&task);
  double worst_speed = 0, worst_overlap = 0;
  for (const auto& [key, tasks] : by_scene) {
    sim::Workcell cell(sim::load_task_scene(*tasks.front(), 0));
    const std::string& cell_name = tasks.front()->suite;
    std::vector<sim::PhysicsState> state(kSeeds + 1);
    for (unsigned seed = 1; seed <= kSeeds; ++seed) {
      const std::string what = cell_name + "/" + std::to_string(tasks.front()->id) + " seed " + std::to_string(seed);
      ASSERT_NO_THROW(cell.reset(seed, tasks.front()->goal)) << what;
      const double speed = cell.max_object_speed(), overlap = cell.max_penetration();
      worst_speed = std::max(worst_speed, speed);
      worst_overlap = std::max(worst_overlap, overlap);
      EXPECT_LT(speed, kAtRest) << what;
      EXPECT_LT(overlap, kMaxPenetration) << what;
      for (const TaskDef* t : tasks)
        EXPECT_FALSE(cell.holds(t->goal)) << t->suite << "/" << t->id << " seed " << seed
                                          << ": the goal already holds in the initial state";
      state[seed] = cell.physics_state();
    }
    // The goal does not change the initial state, so one task per scene key stands for all of them.
    for (unsigned seed = 1; seed <= kRepeatSeeds; ++seed) {
      cell.reset(seed, tasks.back()->goal);
      EXPECT_EQ(cell.physics_state(), state[seed]) << key << ": seed " << seed << " again";
      EXPECT_NE(state[seed], state[seed + 1]) << key << ": seeds " << seed << " and " << seed + 1 << " give one state";
    }
  }
  RecordProperty("worst_object_speed_mps", std::to_string(worst_speed));
  RecordProperty("worst_penetration_m", std::to_string(worst_overlap));
  std::cout << "worst object speed " << worst_speed << " m/s, deepest overlap " << worst_overlap << " m over "
            << by_scene.size() << " scene models\n";
}

// "-pos" cells: each free object within its seed's magnitude x reach_m of its place, in reach, on the
// table and off every named region; fixtures where they were; displacement grows with the magnitude.
TEST(BenchmarkCells, PosCellsDisplaceFreeObjectsWithinTheSeedsMagnitude) {
  for (const char* cell : {"goal-pos", "long-pos"}) {
    std::set<std::string> scenes;
    for (const auto& [id, task] : suites().at(cell).tasks) {
      if (!scenes.insert(sim::task_scene_key(task, 0)).second) continue;
      const sim::SceneSpec spec = sim::load_task_scene(task, 0);
      ASSERT_FALSE(spec.pos.empty()) << cell;
      std::map<double, std::pair<double, int>> mean;  // magnitude -> (sum of displacements, count)
      for (unsigned seed = 1; seed <= 50; ++seed) {
        const double radius = spec.pos.magnitude_for(seed) * spec.pos.reach_m;
        const auto placed = sim::sample_placements(spec, seed);
        for (std::size_t i = 0; i < placed.size(); ++i) {
          const sim::EntitySpec& e = spec.entities[i];
          const double d = std::hypot(placed[i].x - e.nominal_xy[0], placed[i].y - e.nominal_xy[1]);
          const std::string what = std::string(cell) + "/" + std::to_string(id) + " " + e.name + " seed " + std::to_string(seed);
          if (e.fixture()) {
            EXPECT_EQ(d, 0.0) << what;
            continue;
          }
          EXPECT_LE(d, radius + 1e-12) << what;
          const double reach = std::hypot(placed[i].x - spec.robot_base[0], placed[i].y - spec.robot_base[1]);
          EXPECT_GE(reach, sim::kPosMinReach) << what;
          EXPECT_LE(reach, sim::kPosMaxReach) << what;
          EXPECT_GE(placed[i].x, spec.workspace_min[0]) << what;
          EXPECT_LE(placed[i].x, spec.workspace_max[0]) << what;
          for (const auto& r : spec.regions)
            EXPECT_FALSE(std::abs(placed[i].x - r.xy[0]) < r.half[0] && std::abs(placed[i].y - r.xy[1]) < r.half[1])
                << what << " starts on " << r.name;
          mean[spec.pos.magnitude_for(seed)].first += d;
          ++mean[spec.pos.magnitude_for(seed)].second;
        }
      }
      double last = 0;
      for (const auto& [m, sum] : mean) {
        const double avg = sum.first / sum.second;
        EXPECT_GT(avg, last) << cell << " " << spec.name << ": mean displacement at magnitude " << m;
        EXPECT_GT(avg, 0.4 * m * spec.pos.reach_m) << cell << " " << spec.name << " at magnitude " << m;
        last = avg;
      }
    }
  }
}

// Articulated fixtures start as the `:init` of the LIBERO BDDL file each scene models says (notes
// robot-facts.md §5): KITCHEN_SCENE4's bottom drawer open, KITCHEN_SCENE6's microwave door open,
// KITCHEN_SCENE8's stove on; everything else closed and off.
TEST(BenchmarkCells, FixturesStartAsTheLiberoInitOfTheirSceneSays) {
  const std::map<std::string, std::vector<PredicateSpec>> initial{
      {"kitchen_goal.yaml",
       {{"TurnOff", {"stove"}}, {"Close", {"cabinet_top_region"}}, {"Close", {"cabinet_middle_region"}},
        {"Close", {"cabinet_bottom_region"}}}},
      {"kitchen_stove.yaml", {{"TurnOff", {"stove"}}}},
      {"kitchen_two_moka.yaml", {{"TurnOn", {"stove"}}}},
      {"kitchen_cabinet.yaml", {{"Open", {"cabinet_bottom_region"}}}},
      {"kitchen_microwave.yaml", {{"Open", {"microwave"}}}},
  };
  std::set<std::string> seen;
  for (const auto& [cell, suite] : suites())
    for (const auto& [id, task] : suite.tasks) {
      const std::string scene = task.scene_file.filename().string();
      const auto want = initial.find(scene);
      if (want == initial.end() || !seen.insert(scene).second) continue;
      sim::Workcell workcell(sim::load_task_scene(task, 1));
      for (unsigned seed : {1u, 2u}) {
        workcell.reset(seed, task.goal);
        for (const PredicateSpec& p : want->second)
          EXPECT_TRUE(workcell.holds({p})) << scene << " seed " << seed << ": " << p.text() << " at the start";
      }
    }
  EXPECT_EQ(seen.size(), initial.size()) << "a scene of the list is used by no task";
}

}  // namespace
}  // namespace dh

namespace dh {
namespace {

// The tool centre can be driven 8 cm above the top face of every open region a goal names (drawer
// and microwave insides are reached through their openings, not from above, and are left out).
TEST(BenchmarkCells, EveryOpenGoalRegionCanBeReachedFromAbove) {
  std::map<std::string, std::pair<const TaskDef*, std::set<std::string>>> by_scene;
  for (const auto& [cell, suite] : suites())
    for (const auto& [id, task] : suite.tasks) {
      auto& entry = by_scene[sim::task_scene_key(task, 1)];
      entry.first = &task;
      for (const auto& p : task.goal)
        if ((p.name == "On" || p.name == "In") &&
            (p.args[1].find("_region") != std::string::npos || p.args[1].find("_side") != std::string::npos))
          if (p.args[1].rfind("microwave_", 0) != 0 && p.args[1].find("drawer") == std::string::npos &&
              !(p.args[1].rfind("cabinet_", 0) == 0 && p.args[1] != "cabinet_top_side"))
            entry.second.insert(p.args[1]);
    }
  for (const auto& [key, entry] : by_scene) {
    if (entry.second.empty()) continue;
    sim::Workcell cell(sim::load_task_scene(*entry.first, 1));
    for (const auto& region : entry.second) {
      cell.reset(1, entry.first->goal);
      std::array<double, 3> target{};
      for (const auto& e : cell.observe().entities)
        if (e.name == region) target = {e.p[0], e.p[1], e.p[2] + e.half_extents[2] + 0.08};
      double error = 1;
      Observation o;
      for (int step = 0; step < 250 && error > 0.01; ++step) {
        o = cell.observe();
        std::array<double, 7> a{0, 0, 0, 0, 0, 0, -1};
        error = 0;
        for (int k = 0; k < 3; ++k) {
          a[k] = std::clamp((target[k] - o.ee_p[k]) / robot::kMaxDeltaPosM, -1.0, 1.0);
          error += (target[k] - o.ee_p[k]) * (target[k] - o.ee_p[k]);
        }
        error = std::sqrt(error);
        cell.step(a);
      }
      EXPECT_LT(error, 0.01) << key << ": " << region << " at (" << target[0] << ", " << target[1] << ", "
                             << target[2] << ") is out of reach; the tool stopped at (" << o.ee_p[0] << ", "
                             << o.ee_p[1] << ", " << o.ee_p[2] << ")";
    }
  }
}

}  // namespace
}  // namespace dh

namespace dh {
namespace {

// "-object" cells: every free object redrawn within the bounds of configs/suites/object/objects.yaml
// (against its own instance's nominal size and mass), fixtures and names untouched, some objects another
// instance, the seed's scene settling at rest with the goal unmet, and the same draw for the same seed.
TEST(BenchmarkCells, ObjectCellsVaryEveryFreeObjectWithinItsBoundsAndSettle) {
  constexpr unsigned kObjectSeeds = 20;
  std::set<std::string> instances_seen;
  unsigned varied = 0;
  for (const char* name : {"goal-object", "long-object"}) {
    std::map<std::filesystem::path, std::vector<const TaskDef*>> by_scene;
    for (const auto& [id, task] : suites().at(name).tasks) by_scene[task.scene_file].push_back(&task);
    for (const auto& [file, tasks] : by_scene) {
      const TaskDef& task = *tasks.front();
      const unsigned id = task.id;
      const ObjectSpec& o = task.object;
      ASSERT_FALSE(o.empty()) << name;
      const sim::SceneSpec nominal = sim::load_nominal_scene(task);
      const auto assets = task.scene_file.parent_path() / ".." / "assets";
      for (unsigned seed = 1; seed <= kObjectSeeds; ++seed) {
        const sim::SceneSpec spec = sim::load_task_scene(task, seed);
        ASSERT_EQ(spec.entities.size(), nominal.entities.size());
        for (std::size_t i = 0; i < spec.entities.size(); ++i) {
          const sim::EntitySpec &e = spec.entities[i], &n = nominal.entities[i];
          const std::string what = std::string(name) + "/" + std::to_string(id) + " " + e.name + " seed " + std::to_string(seed);
          EXPECT_EQ(e.name, n.name);
          EXPECT_EQ(e.colour, n.colour) << what;
          EXPECT_EQ(e.nominal_xy, n.nominal_xy) << what;
          if (e.fixture()) {
            EXPECT_TRUE(e.variation.empty()) << what;
            EXPECT_EQ(e.asset.half_extents(), n.asset.half_extents()) << what;
            continue;
          }
          ASSERT_FALSE(e.variation.empty()) << what;
          ++varied;
          const std::string instance = e.variation.substr(0, e.variation.find(' '));
          const sim::AssetSpec base = sim::load_asset(assets / (instance + ".yaml"));
          EXPECT_EQ(base.kind, n.asset.kind) << what;
          if (instance != n.asset.name) instances_seen.insert(instance);
          const auto h = e.asset.half_extents(), h0 = base.half_extents();
          for (int k = 0; k < 2; ++k) {
            EXPECT_GE(h[k] / h0[k], o.width[0] - 0.02) << what;
            EXPECT_LE(h[k] / h0[k], o.width[1] + 0.02) << what;
          }
          EXPECT_GE(h[2] / h0[2], o.height[0] - 1e-9) << what;
          EXPECT_LE(h[2] / h0[2], o.height[1] + 1e-9) << what;
          EXPECT_GE(e.asset.mass / base.mass, o.mass[0] - 1e-9) << what;
          EXPECT_LE(e.asset.mass / base.mass, o.mass[1] + 1e-9) << what;
          for (int c = 0; c < 3; ++c) {
            EXPECT_LE(e.rgba[c], std::min(1.0, n.rgba[c] * (1 + o.shade)) + 1e-12) << what;
            EXPECT_GE(e.rgba[c], n.rgba[c] * (1 - o.shade) - 1e-12) << what;
          }
        }
        EXPECT_EQ(sim::load_task_scene(task, seed).entities.back().variation, spec.entities.back().variation);
        sim::Workcell cell(spec);
        ASSERT_NO_THROW(cell.reset(seed, task.goal)) << name << "/" << id << " seed " << seed;
        EXPECT_LT(cell.max_object_speed(), kAtRest) << name << "/" << id << " seed " << seed;
        EXPECT_LT(cell.max_penetration(), kMaxPenetration) << name << "/" << id << " seed " << seed;
        for (const TaskDef* t : tasks) EXPECT_FALSE(cell.holds(t->goal)) << name << "/" << t->id << " seed " << seed;
      }
    }
  }
  EXPECT_GT(varied, 100u);
  EXPECT_EQ(instances_seen, (std::set<std::string>{"bowl_deep", "plate_wide", "mug_tall"}));
}

}  // namespace
}  // namespace dh
