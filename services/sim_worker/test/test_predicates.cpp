// Goal predicates evaluated on constructed simulator states of the real scenes.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "dh/common/paths.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/predicates.hpp"
#include "dh/sim/scene.hpp"

namespace dh {
namespace {

/// One scene compiled at seed 1, with helpers to pose objects and joints directly.
class SceneState {
 public:
  explicit SceneState(const std::string& scene_file)
      : scene_(sim::load_scene(paths::config_dir() / "scenes" / scene_file)),
        m_(sim::compile_model(sim::scene_mjcf(scene_, sim::sample_placements(scene_, 1)), scene_file)),
        d_(sim::make_data(m_.get())) {
    mj_forward(m_.get(), d_.get());
  }
  /// Puts free object `name` with its bottom centre at (x, y, z), upright.
  void place(const std::string& name, double x, double y, double z) {
    double* q = d_->qpos + m_->jnt_qposadr[id(mjOBJ_JOINT, name + "_free")];
    q[0] = x, q[1] = y, q[2] = z, q[3] = 1, q[4] = q[5] = q[6] = 0;
  }
  void joint(const std::string& name, double value) { d_->qpos[m_->jnt_qposadr[id(mjOBJ_JOINT, name)]] = value; }
  void push(const std::string& name, double vx) { d_->qvel[m_->jnt_dofadr[id(mjOBJ_JOINT, name + "_free")]] = vx; }
  const double* site(const std::string& name) { return d_->site_xpos + 3 * id(mjOBJ_SITE, name); }
  bool holds(const std::vector<PredicateSpec>& goal) {
    forward();
    return sim::GoalEvaluator(m_.get(), scene_, goal).holds(d_.get());
  }
  void run(double seconds) {
    for (int i = 0; i < static_cast<int>(seconds / m_->opt.timestep); ++i) mj_step(m_.get(), d_.get());
  }
  std::string error_of(const std::vector<PredicateSpec>& goal) {
    try {
      sim::GoalEvaluator(m_.get(), scene_, goal);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  }
  void forward() { mj_forward(m_.get(), d_.get()); }

 private:
  int id(mjtObj type, const std::string& name) {
    const int i = mj_name2id(m_.get(), type, name.c_str());
    if (i < 0) throw std::runtime_error("no " + name);
    return i;
  }
  sim::SceneSpec scene_;
  sim::ModelPtr m_;
  sim::DataPtr d_;
};

const PredicateSpec kBowlOnPlate{"On", {"bowl", "plate"}};

TEST(Predicates, OnAnObjectNeedsContactAndOriginsWithin3cm) {
  SceneState s("kitchen_goal.yaml");
  s.place("plate", -0.1, 0.2, 0.0);
  s.place("bowl", -0.1, 0.2, 0.0095);  // resting on the plate's 10 mm floor (0.5 mm overlap: in contact)
  EXPECT_TRUE(s.holds({kBowlOnPlate}));
  s.place("bowl", -0.1 + 0.032, 0.2, 0.0095);  // still touching, 3.2 cm off centre
  EXPECT_FALSE(s.holds({kBowlOnPlate}));
  s.place("bowl", -0.1, 0.2, 0.03);  // above the plate, not touching it
  EXPECT_FALSE(s.holds({kBowlOnPlate}));
  s.place("bowl", -0.1, 0.2, 0.0095);
  EXPECT_FALSE(s.holds({{"On", {"plate", "bowl"}}})) << "the plate is below the bowl";
}

TEST(Predicates, ATransientSuccessThatEndsIsFalseAgain) {
  SceneState s("kitchen_goal.yaml");
  s.place("plate", -0.1, 0.2, 0.0);
  s.place("bowl", -0.1, 0.2, 0.0125);
  s.run(0.2);
  ASSERT_TRUE(s.holds({kBowlOnPlate}));
  s.push("bowl", 1.5);  // shoved along +x: it slides off the plate
  s.run(0.5);
  EXPECT_FALSE(s.holds({kBowlOnPlate}));
}

TEST(Predicates, OnARegionNeedsTheOriginOverItAndContactWithItsCarrier) {
  SceneState s("kitchen_goal.yaml");
  const double* cook = s.site("stove_cook_region");
  const PredicateSpec on_stove{"On", {"bowl", "stove_cook_region"}};
  s.place("bowl", cook[0], cook[1], 0.0455);  // on the burner, whose top is at 46 mm
  EXPECT_TRUE(s.holds({on_stove}));
  s.place("bowl", cook[0] + 0.075, cook[1], 0.0455);  // past the region's 7 cm half size
  EXPECT_FALSE(s.holds({on_stove}));
  s.place("bowl", cook[0], cook[1], 0.12);  // hovering: inside the height band, no contact
  EXPECT_FALSE(s.holds({on_stove}));
  // A table region: the carrier is the table.
  const double* front = s.site("stove_front_region");
  const double fx = front[0], fy = front[1];
  s.place("plate", fx, fy, -0.0005);
  EXPECT_TRUE(s.holds({{"On", {"plate", "stove_front_region"}}}));
  s.place("plate", fx, fy + 0.09, -0.0005);
  EXPECT_FALSE(s.holds({{"On", {"plate", "stove_front_region"}}}));
}

TEST(Predicates, InARegionIsTheOriginInsideItsBox) {
  SceneState s("kitchen_goal.yaml");
  s.joint("cabinet_top_drawer_joint", 0.16);
  s.forward();
  const double* top = s.site("cabinet_top_region");
  const PredicateSpec in_drawer{"In", {"bowl", "cabinet_top_region"}};
  s.place("bowl", top[0], top[1], top[2] - 0.035 + 0.0005);  // on the drawer floor
  EXPECT_TRUE(s.holds({in_drawer}));
  EXPECT_FALSE(s.holds({{"In", {"bowl", "cabinet_middle_region"}}}));
  s.place("bowl", top[0] - 0.2, top[1], top[2]);  // in front of the drawer
  EXPECT_FALSE(s.holds({in_drawer}));
}

TEST(Predicates, InIsFalseForAnObjectLyingOnTheRimAboveTheRegion) {
  SceneState s("study_caddy.yaml");
  const double* back = s.site("caddy_back_contain_region");
  const PredicateSpec in_back{"In", {"book", "caddy_back_contain_region"}};
  s.place("book", back[0], back[1], back[2] - 0.025 + 0.0005);  // on the compartment floor
  EXPECT_TRUE(s.holds({in_back}));
  s.place("book", back[0], back[1], 0.0695);  // across the 7 cm rim
  EXPECT_FALSE(s.holds({in_back}));
}

TEST(Predicates, OpenCloseTurnOnTurnOffAreJointIntervals) {
  SceneState s("kitchen_goal.yaml");
  const PredicateSpec open{"Open", {"cabinet_middle_region"}}, close{"Close", {"cabinet_middle_region"}};
  EXPECT_TRUE(s.holds({close}));
  EXPECT_FALSE(s.holds({open}));
  s.joint("cabinet_middle_drawer_joint", 0.08);  // half out: neither
  EXPECT_FALSE(s.holds({open}));
  EXPECT_FALSE(s.holds({close}));
  s.joint("cabinet_middle_drawer_joint", 0.15);
  EXPECT_TRUE(s.holds({open}));
  EXPECT_TRUE(s.holds({{"Open", {"cabinet_middle_drawer"}}})) << "the part may be named directly";
  EXPECT_FALSE(s.holds({{"Open", {"cabinet_top_region"}}}));
  EXPECT_TRUE(s.holds({{"TurnOff", {"stove"}}}));
  EXPECT_FALSE(s.holds({{"TurnOn", {"stove"}}}));
  s.joint("stove_knob_joint", 1.0);
  EXPECT_TRUE(s.holds({{"TurnOn", {"stove"}}}));
  EXPECT_FALSE(s.holds({{"TurnOff", {"stove"}}}));
  EXPECT_TRUE(s.holds({open, {"TurnOn", {"stove"}}})) << "a conjunction of true terms";
  EXPECT_FALSE(s.holds({open, close})) << "a conjunction with a false term";
  EXPECT_FALSE(s.holds({})) << "an empty goal never holds";

  SceneState mw("kitchen_microwave.yaml");
  EXPECT_TRUE(mw.holds({{"Close", {"microwave"}}}));
  mw.joint("microwave_door_joint", -1.6);
  EXPECT_TRUE(mw.holds({{"Open", {"microwave"}}}));
  EXPECT_FALSE(mw.holds({{"Close", {"microwave"}}}));
}

TEST(Predicates, TermsNamingWhatTheSceneLacksAreRefusedWithTheName) {
  SceneState s("kitchen_goal.yaml");
  EXPECT_NE(s.error_of({{"On", {"bowl", "sink"}}}).find("no entity or region named 'sink'"), std::string::npos);
  EXPECT_NE(s.error_of({{"In", {"bowl", "plate"}}}).find("no region named 'plate'"), std::string::npos);
  EXPECT_NE(s.error_of({{"On", {"cabinet", "plate"}}}).find("'cabinet' is not a movable object"), std::string::npos);
  EXPECT_NE(s.error_of({{"Open", {"cabinet"}}}).find("'cabinet' has 3 articulated parts"), std::string::npos);
  EXPECT_NE(s.error_of({{"Open", {"bowl"}}}).find("no articulated part"), std::string::npos);
  EXPECT_NE(s.error_of({{"TurnOn", {"cabinet_top_region"}}}).find("declares no 'on' state"), std::string::npos);
  EXPECT_NE(s.error_of({{"Levitate", {"bowl"}}}).find("unknown predicate 'Levitate'"), std::string::npos);
}

TEST(Predicates, GoalTermsNameThePartAndTheIntervalTheSimulatorJudgesBy) {
  const sim::SceneSpec scene = sim::load_scene(paths::config_dir() / "scenes" / "kitchen_goal.yaml");
  const auto terms = sim::goal_terms(scene, {{"Open", {"cabinet_middle_region"}}, kBowlOnPlate, {"TurnOn", {"stove"}}});
  ASSERT_EQ(terms.size(), 3u);
  EXPECT_EQ(terms[0].part, "cabinet_middle_drawer");
  // The interval the oracle uses: 0.15 m is open, 0.08 m is not (the test above).
  EXPECT_LE(terms[0].lo, 0.15);
  EXPECT_GE(terms[0].hi, 0.15);
  EXPECT_GT(terms[0].lo, 0.08);
  EXPECT_FALSE(terms[1].articulated());
  EXPECT_EQ(terms[1].text(), "On(bowl, plate)");
  EXPECT_EQ(terms[2].part, "stove_knob");
  EXPECT_LE(terms[2].lo, 1.0);
  EXPECT_GE(terms[2].hi, 1.0);
  const auto error = [&](const std::vector<PredicateSpec>& goal) {
    try {
      sim::goal_terms(scene, goal);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error({{"Open", {"cabinet"}}}).find("'cabinet' has 3 articulated parts"), std::string::npos);
  EXPECT_NE(error({{"Levitate", {"bowl"}}}).find("unknown predicate 'Levitate'"), std::string::npos);
  EXPECT_NE(error({{"On", {"bowl"}}}).find("takes two arguments"), std::string::npos);
}

}  // namespace
}  // namespace dh
