// A tabletop scene from YAML (configs/scenes/): a table with named regions, the robot, and entities —
// instances of assets (configs/assets/), free objects or fixtures. A seed fixes every free object's
// initial pose exactly; fixtures stand where the scene (or a swap perturbation) puts them.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "dh/common/robot_contract.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/asset.hpp"
#include "dh/sim/contact_exclusion.hpp"
#include "dh/sim/robot_model.hpp"

namespace dh::sim {

struct EntitySpec {
  std::string name;  ///< body name in the model and in observations, e.g. "bowl", "cabinet"
  AssetSpec asset;
  std::array<double, 4> rgba{};        ///< the asset's colour unless the scene paints it
  std::string colour;                  ///< the same in words
  std::array<double, 2> nominal_xy{};  ///< m, world frame
  double yaw = 0;                      ///< nominal rotation about z (rad)
  double jitter = 0;                   ///< uniform ± on x and y per seed (m); fixtures: 0
  double yaw_jitter = 0;               ///< uniform ± per seed (rad)
  std::map<std::string, double> init_joints;  ///< part name → initial joint position
  std::string variation;  ///< an object cell's draw for this seed (object_variation.hpp); empty elsewhere
  bool fixture() const { return asset.fixture; }
};

/// A named box on the table top (e.g. "stove_front_region"); its top face is the table surface.
struct TableRegion {
  std::string name;
  std::string relation;  ///< to `of`, as the robot sees it: front_of, back_of, left_of, right_of
  std::string of;        ///< the entity it is named after
  std::array<double, 2> xy{};
  std::array<double, 2> half{};
};

/// A fixed camera the model carries besides agentview and wrist (an RGB-D workcell camera, rgbd.hpp):
/// at `pos`, aimed at `look_at` with the world's z up in the image, vertical field of view `fovy`
/// (degrees), rendered at width x height (the model's offscreen buffer is made at least that large).
struct CameraSpec {
  std::string name;
  std::array<double, 3> pos{}, look_at{};
  double fovy = 45;
  int width = 640, height = 480;
};

/// Doubles of mjData's userdata: the arm controller's orientation goal (w x y z), the one piece of its state
/// that outlives a control step (osc_pose.hpp), kept there so the physics state stays the whole state.
inline constexpr int kUserdataSize = 4;

struct SceneSpec {
  std::filesystem::path file;
  std::string name;
  std::string layout;  ///< kitchen, living_room, study
  std::array<double, 3> table_size{};  ///< full extents; the top is at z = 0
  double table_friction = 1.0;
  std::array<double, 4> table_rgba{0.6, 0.45, 0.3, 1};
  RobotSpec robot;
  std::string robot_profile;  ///< the profile's name (configs/robots/<name>.yaml): "panda", "ur7e"
  std::array<double, 3> robot_base{};
  std::vector<double> ready_q;  ///< one per arm joint
  robot::Gripper gripper;       ///< the jaw's shape about the tool centre point, from the robot profile
  std::array<double, 3> workspace_min{}, workspace_max{};
  double finger_friction = 1.5;
  /// The arm controller behind the seam: "osc_pose" (robosuite's, osc_pose.hpp; docs/controller.md), what
  /// LIBERO runs and the skills are tuned to, or "joint_ik" (joint_ik.hpp, the controller before it).
  std::string controller = "osc_pose";
  std::vector<EntitySpec> entities;
  std::vector<TableRegion> regions;
  /// Extra fixed cameras (not from the scene file: sim_worker adds configs/cameras.yaml's); none by default.
  std::vector<CameraSpec> cameras;
  /// A "-pos" cell's position perturbation (sample_placements); none elsewhere.
  PosSpec pos;

  const EntitySpec* entity(const std::string& name) const;
};

/// An entity's initial pose for one seed.
struct Placement {
  std::string name;
  double x = 0, y = 0, yaw = 0;
};

/// Loads a scene and its assets (<scene dir>/../assets/<asset>.yaml); throws ConfigError naming file and key.
/// The arm is the robot profile the scene names (`robot: {profile: ../robots/panda.yaml, base: [...]}`: its
/// URDF, ready pose, pad friction and jaw shape), or `robot`, a profile file, in its place on the scene's
/// mount.
SceneSpec load_scene(const std::filesystem::path& file, const std::filesystem::path& robot = {});

/// The profile file of the robot named `name` (configs/robots/<name>.yaml); ConfigError listing the robots
/// there when it has none.
std::filesystem::path robot_profile(const std::string& name);

/// The scene with `swap` applied (entities trade nominal xy; each keeps its orientation and jitter);
/// throws std::invalid_argument naming an entity the scene lacks.
SceneSpec apply_swap(SceneSpec scene, const SwapSpec& swap);

/// The scene an episode of `task` with `seed` runs in: its scene file with the task's swap, position and
/// object perturbations applied.
/// `robot` names a robot profile (robot_profile) that stands in for the scene's own arm; "": the scene's.
SceneSpec load_task_scene(const TaskDef& task, std::uint64_t seed, const std::string& robot = "");
/// The same before the seed's object perturbation: what a perceiver knows of the scene beforehand.
SceneSpec load_nominal_scene(const TaskDef& task, const std::string& robot = "");
/// Episodes with equal keys share one compiled model (an object cell's key includes the seed).
std::string task_scene_key(const TaskDef& task, std::uint64_t seed, const std::string& robot = "");

/// Horizontal distance from the robot's base within which a displaced object must stand (m): no nearer
/// than the scenes' own nearest place allows (kitchen_goal's cream cheese, 0.26 m less its 2 cm jitter;
/// nearer, the top-down hand cannot come down), no farther than the farthest (living_room_pudding's
/// pudding, 0.71 m) and its jitter.
inline constexpr double kPosMinReach = 0.24, kPosMaxReach = 0.75;

/// Samples placements for `seed` (deterministic, every entity, fixtures at their nominal pose) with
/// footprints apart. Free objects are jittered about their place, or under a position perturbation drawn
/// from its disc, on the table, inside the workspace box, within kPosMinReach..kPosMaxReach of the base
/// and clear of the table's regions. Throws std::runtime_error when no placement is found.
std::vector<Placement> sample_placements(const SceneSpec& scene, std::uint64_t seed);

/// Every entity at its nominal place and yaw: what the workcell's model is compiled with (a reset moves
/// the free objects to their seed's placements).
std::vector<Placement> nominal_placements(const SceneSpec& scene);

/// The complete MJCF document of the workcell with entities at `placements`, with the cameras
/// "agentview" and "wrist" (camera.hpp) and the scene's extra `cameras`, which do not touch the physics.
/// `exclude`: body pairs left out of collision detection (never_touching in contact_exclusion.hpp).
std::string scene_mjcf(const SceneSpec& scene, const std::vector<Placement>& placements,
                       const std::vector<BodyPair>& exclude = {});

/// MJCF names: a part body is "<entity>_<part>", its joint "<entity>_<part>_joint", an asset site
/// "<entity>_<site>" (also for sites on parts), a table region keeps its own name; a part's grip site is
/// "<entity>_<part>_grip".
std::string part_body(const std::string& entity, const std::string& part);
std::string part_joint(const std::string& entity, const std::string& part);
std::string part_grip_site(const std::string& entity, const std::string& part);

}  // namespace dh::sim
