// A rendered RGB-D frame's camera on the wire (idl/camera.idl), for the processes that render the simulated
// world: sim_worker's channels and the RTDE test controller.
#pragma once

#include "dh/msg/camera.h"
#include "dh/sim/rgbd.hpp"

namespace dh::sim {

/// Sets `m`'s size and intrinsics from `K` and its pose (world from camera, OpenCV convention) from `pose`.
inline void set_camera(msg::RgbdFrame& m, const Pinhole& K, const CameraPose& pose) {
  m.width(static_cast<std::uint32_t>(K.width));
  m.height(static_cast<std::uint32_t>(K.height));
  m.fx(K.fx);
  m.fy(K.fy);
  m.cx(K.cx);
  m.cy(K.cy);
  m.has_pose(true);
  m.position(pose.position);
  m.orientation(pose.wxyz);
}

}  // namespace dh::sim
