// The body pairs left out of collision detection can never touch: every scene simulates the same, bit for
// bit, with and without the exclusions, while the arm falls limp through the fixtures and every slide
// (the drawers) is driven across its whole range.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "dh/common/paths.hpp"
#include "dh/sim/contact_exclusion.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/scene.hpp"

namespace dh {
namespace {

bool has(const std::vector<sim::BodyPair>& pairs, const std::string& a, const std::string& b) {
  return std::find(pairs.begin(), pairs.end(), sim::BodyPair{a, b}) != pairs.end() ||
         std::find(pairs.begin(), pairs.end(), sim::BodyPair{b, a}) != pairs.end();
}

TEST(ContactExclusion, TheStackedDrawersAreLeftOutAndTheirCabinetIsNot) {
  const sim::SceneSpec scene = sim::load_scene(paths::config_dir() / "scenes/kitchen_goal.yaml");
  const std::string xml = sim::scene_mjcf(scene, sim::sample_placements(scene, 21));
  const sim::ModelPtr m = sim::compile_model(xml, "goal");
  const auto pairs = sim::never_touching(m.get());
  // From the document: compiled the first time (the model handed over), remembered the second.
  sim::ModelPtr first, second;
  EXPECT_EQ(sim::never_touching(xml, "goal", &first), pairs);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->nbody, m->nbody);
  EXPECT_EQ(sim::never_touching(xml, "goal", &second), pairs);
  EXPECT_FALSE(second) << "a remembered document is not compiled again";
  EXPECT_TRUE(has(pairs, "cabinet_top_drawer", "cabinet_middle_drawer"));
  EXPECT_TRUE(has(pairs, "cabinet_middle_drawer", "cabinet_bottom_drawer"));
  // The drawers run on the cabinet's rails, the objects and the arm move anywhere.
  for (const auto& [a, b] : pairs) {
    for (const std::string& body : {a, b}) {
      EXPECT_NE(body, "cabinet") << a << " | " << b;
      EXPECT_EQ(body.find("link"), std::string::npos) << a << " | " << b;
      for (const auto& e : scene.entities) {
        if (!e.fixture()) {
          EXPECT_NE(body, e.name) << a << " | " << b;
        }
      }
    }
  }
}

TEST(ContactExclusion, EverySceneSimulatesTheSameBitForBitWithoutTheExcludedPairs) {
  int scenes_with_exclusions = 0;
  for (const auto& file : std::filesystem::directory_iterator(paths::config_dir() / "scenes")) {
    const sim::SceneSpec scene = sim::load_scene(file.path());
    const auto placements = sim::sample_placements(scene, 21);
    const sim::ModelPtr all = sim::compile_model(sim::scene_mjcf(scene, placements), scene.name);
    const auto exclude = sim::never_touching(all.get());
    if (exclude.empty()) continue;
    ++scenes_with_exclusions;
    const sim::ModelPtr filtered =
        sim::compile_model(sim::scene_mjcf(scene, placements, exclude), scene.name);
    ASSERT_EQ(filtered->nexclude, static_cast<int>(exclude.size()));
    const sim::DataPtr a = sim::make_data(all.get()), b = sim::make_data(filtered.get());
    const mjModel* m = all.get();
    int contacts = 0;
    for (int step = 0; step < 1500; ++step) {
      // Every slide pushed one way for its first half-second... then back: across its range and into its
      // stops. The arm has no control and falls onto what stands below it.
      const double sign = (step / 250) % 2 == 0 ? 1.0 : -1.0;
      for (mjData* d : {a.get(), b.get()})
        for (int j = 0; j < m->njnt; ++j)
          if (m->jnt_type[j] == mjJNT_SLIDE && m->body_weldid[m->body_parentid[m->jnt_bodyid[j]]] == 0)
            d->qfrc_applied[m->jnt_dofadr[j]] = 40 * sign;
      mj_step(all.get(), a.get());
      mj_step(filtered.get(), b.get());
      contacts += a->ncon;
      ASSERT_EQ(a->ncon, b->ncon) << scene.name << " substep " << step;
      ASSERT_EQ(0, std::memcmp(a->qpos, b->qpos, sizeof(mjtNum) * m->nq))
          << scene.name << " substep " << step;
      ASSERT_EQ(0, std::memcmp(a->qvel, b->qvel, sizeof(mjtNum) * m->nv))
          << scene.name << " substep " << step;
    }
    EXPECT_GT(contacts, 0) << scene.name;
  }
  EXPECT_GE(scenes_with_exclusions, 3);  // the kitchens with a cabinet of drawers at least
}

}  // namespace
}  // namespace dh
