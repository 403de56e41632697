// Where a seed puts a scene's entities in a model compiled from it: the one way every simulation of a
// scene starts an episode, the workcell behind the seam and the RTDE test controller's arm alike.
#pragma once

#include <vector>

#include "dh/sim/scene.hpp"

struct mjModel_;
struct mjData_;

namespace dh::sim {

/// Puts each free object of `scene` at its placement (`placements[k]` is `scene.entities[k]`'s, as
/// sample_placements gives them), 1 mm above the table and turned by its yaw, and each part at the
/// scene's initial joint value, in `d` of a model compiled from scene_mjcf(scene, ...). Touches nothing
/// else. Throws std::invalid_argument naming a body or joint the model lacks.
void place_entities(const mjModel_* m, mjData_* d, const SceneSpec& scene,
                    const std::vector<Placement>& placements);

}  // namespace dh::sim
