// The frame a MuJoCo camera of configs/cameras.yaml shows, as the perception library takes it: for the
// tools that measure perception against the simulator's truth, and for perception on the in-process bus.
#pragma once

#include <cstddef>

#include "dh/perception/frame.hpp"
#include "dh/sim/camera.hpp"

namespace dh::perception {

/// Renders camera `index` of `rig` (colour and depth, the rig's size) in the state `d` of `m`, stamped
/// with its simulated time.
RgbdFrame rendered_frame(sim::CameraRig& rig, std::size_t index, const mjModel_* m, const mjData_* d);

}  // namespace dh::perception
