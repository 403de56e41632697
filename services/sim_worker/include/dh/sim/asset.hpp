// Objects and fixtures built from primitives, described in YAML (configs/assets/*.yaml).
// Every asset's origin is its bottom centre, z up; a fixture's front (drawers, knob, door) faces -x, so at
// yaw 0 it faces a robot standing at -x.
// A free object is one rigid body; a fixture is static, with optional articulated parts (drawers,
// doors, knobs: one slide or hinge joint each) whose joint intervals name states (open, closed, on, off).
// Sites are regions (boxes) used by the predicates On and In.
#pragma once

#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace dh::sim {

struct GeomSpec {
  // Disc: a cylinder built from `segments` boxes turned about z. MuJoCo 2.2 gives a flat cylinder one
  // contact point on a table, so plates rock and sink up to 2 cm; boxes rest on several.
  enum class Type { Box, Cylinder, Disc, Ring };
  Type type = Type::Box;
  /// box: half extents; cylinder, disc: radius, half height; ring: outer radius, wall thickness, half height.
  std::array<double, 3> size{};
  std::array<double, 3> pos{};  ///< centre, in the body frame (m)
  double yaw = 0;               ///< rotation about z (rad)
  std::optional<std::array<double, 4>> rgba;  ///< own colour; default: the entity's colour
  int segments = 16;            ///< ring: number of wall boxes; disc: number of boxes (default 4)
  double volume() const;  ///< of what MuJoCo builds (the boxes, for discs and rings)
};

struct SiteSpec {
  std::string name;
  std::string relation;          ///< to the body it is on: "in" (a container's inside) or "on" (a surface)
  std::array<double, 3> half{};  ///< half extents of the region box (m)
  std::array<double, 3> pos{};   ///< centre in the body frame; a support region's top face is its surface
};

struct JointSpec {
  enum class Type { Slide, Hinge };
  Type type = Type::Slide;
  std::array<double, 3> axis{1, 0, 0};
  std::array<double, 2> range{};
  double damping = 1.0;
  double frictionloss = 0.0;
  double stiffness = 0.0;  ///< spring towards qpos 0 (e.g. a door that swings shut); 0 = none
  /// Named states as closed intervals of the joint position, e.g. open: [0.14, 0.2].
  std::map<std::string, std::array<double, 2>> states;
};

struct PartSpec {
  std::string name;
  std::string kind;  ///< what capabilities call it: drawer, knob, door
  std::array<double, 3> pos{};  ///< joint anchor / part origin in the asset frame
  JointSpec joint;
  double mass = 0.3;
  std::vector<GeomSpec> geoms;
  std::vector<SiteSpec> sites;
  /// Where a hand takes the part (handle bar, knob lever), in the part frame; observed as the part's pose.
  SiteSpec grip;
};

struct AssetSpec {
  std::filesystem::path file;
  std::string name;
  std::string kind;     ///< what perception and capabilities call it: bowl, plate, mug, box, cabinet, ...
  std::string category; ///< what a person calls it: "cream cheese", "wine bottle" (default: the kind)
  std::string colour;   ///< in words, "black"; a scene may repaint an entity and say so
  bool fixture = false; ///< static (welded into the world by construction, never by a constraint)
  double mass = 0.1;    ///< free objects (kg), spread over the geoms by volume
  double friction = 1.0;
  std::array<double, 4> rgba{0.5, 0.5, 0.5, 1};
  std::vector<GeomSpec> geoms;
  std::vector<SiteSpec> sites;
  std::vector<PartSpec> parts;

  /// Half extents of the root body's bounding box about its origin in x, y; z: half the height.
  std::array<double, 3> half_extents() const;
  /// Half extents of the footprint on the table (root and parts), for placement without overlap.
  std::array<double, 2> footprint() const;
};

/// Loads `file`; throws ConfigError naming file and key.
AssetSpec load_asset(const std::filesystem::path& file);

}  // namespace dh::sim
