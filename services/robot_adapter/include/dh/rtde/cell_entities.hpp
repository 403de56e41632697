// The cell's calibration: where the arm's base stands, and its static entities (its fixtures, their parts
// and the regions a task names), as measured in the world frame (table top at z = 0, z up). On a real cell nothing computes them from a
// model: the adapter reads them from a file and puts them in every observation, beside the arm's state.
// Free objects are not in it: under perception grounding the governor and the capabilities place them
// where the perception service saw them.
//
//   base: [-0.56, 0, 0, 0]      # optional: the arm's base, x, y, z (m), yaw (rad); else robot_adapter --base
//   entities:
//     - {name: cabinet, kind: cabinet, p: [0.05, -0.3, 0], half_extents: [0.1, 0.15, 0.2]}
//     - {name: cabinet_top_drawer, kind: drawer, p: [-0.06, -0.3, 0.25], half_extents: [0.01, 0.05, 0.01],
//        joint: 0, owner: cabinet}
//     - {name: plate_region, kind: region, p: [-0.2, 0.22, 0], half_extents: [0.06, 0.06, 0.02],
//        owner: plate, relation: on}
//
// `kind` is what capabilities call it, as in the simulator's observation: a fixture's asset kind (cabinet,
// stove, ...), a part's drawer, door or knob (which need their `owner`), or region (which needs its
// `owner` and `relation`). `p` is a fixture's bottom centre, a part's grip centre, a region's centre. `q`
// (w, x, y, z) defaults to no rotation; `category` to the kind; `joint` (a part's joint position, m or
// rad, at calibration) to 0: perception's fit of the part replaces it once it has one (perception
// --parts-camera).
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh::rtde {

/// Reads `file`; throws ConfigError naming the file and key for a missing field, a list of the wrong
/// length, a duplicate name, a part without its owner in the file, or a region without owner or relation.
std::vector<EntityState> load_cell_entities(const std::filesystem::path& file);

/// The arm's base in the world: x, y, z (m), yaw about z (rad).
using ArmBase = std::array<double, 4>;

/// The file's `base`, if it has one; ConfigError for one that is not 4 numbers.
std::optional<ArmBase> load_cell_base(const std::filesystem::path& file);

/// `entities` (and `base`) in that format, every key written (0.1 µm and 1e-9 of a quaternion), so that
/// load_cell_entities and load_cell_base give them back: what the test controller's world tells the
/// adapter, as a calibration tells it a real cell's.
std::string cell_entities_yaml(const std::vector<EntityState>& entities, const std::optional<ArmBase>& base = {});

}  // namespace dh::rtde
