// A tabletop scene from YAML (configs/scenes/): a table, the robot, objects built from primitives.
// A seed fixes every object's initial pose exactly.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "dh/sim/robot_model.hpp"

namespace dh::sim {

/// Object kinds built from primitives. Every object's body origin is its bottom centre.
enum class ObjectKind { Bowl, Plate, Box, Cylinder };

struct ObjectSpec {
  std::string name;
  ObjectKind kind = ObjectKind::Box;
  std::string kind_name;
  double radius = 0;              ///< bowl, plate, cylinder (m)
  double height = 0;              ///< all kinds (m)
  double wall = 0;                ///< bowl wall thickness (m)
  std::array<double, 3> size{};   ///< box full extents (m)
  double mass = 0.1;              ///< kg
  double friction = 1.0;
  std::array<double, 4> rgba{0.5, 0.5, 0.5, 1};
  std::array<double, 2> nominal_xy{};  ///< m, world frame
  double jitter = 0;              ///< uniform ± on x and y (m)
  double yaw_jitter = 0;          ///< uniform ± (rad)
  double footprint_radius() const;
  std::array<double, 3> half_extents() const;
};

struct SceneSpec {
  std::filesystem::path file;
  std::string name;
  std::array<double, 3> table_size{};  ///< full extents; the top is at z = 0
  double table_friction = 1.0;
  RobotSpec robot;
  std::array<double, 3> robot_base{};
  std::array<double, 7> ready_q{};
  std::array<double, 3> workspace_min{}, workspace_max{};
  double finger_friction = 1.5;
  std::vector<ObjectSpec> objects;
};

/// An object's initial pose for one seed.
struct Placement {
  std::string name;
  double x = 0, y = 0, yaw = 0;
};

/// Loads a scene; throws ConfigError naming file and key on any problem.
SceneSpec load_scene(const std::filesystem::path& file);

/// Samples non-overlapping placements for `seed` (deterministic); throws std::runtime_error when no
/// placement without overlap is found.
std::vector<Placement> sample_placements(const SceneSpec& scene, std::uint64_t seed);

/// The complete MJCF document of the workcell with objects at `placements`.
std::string scene_mjcf(const SceneSpec& scene, const std::vector<Placement>& placements);

}  // namespace dh::sim
