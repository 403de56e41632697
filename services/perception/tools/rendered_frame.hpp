// The frame a MuJoCo camera of configs/cameras.yaml shows, as the perception library takes it: for the
// tools that measure perception against the simulator's truth.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "dh/perception/frame.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"

namespace dh::perception::tools {

/// Renders camera `index` of `rig` (colour and depth, 640 x 480) in the state `d` of `m`.
inline RgbdFrame rendered_frame(sim::CameraRig& rig, std::size_t index, const mjModel_* m, const mjData_* d) {
  const std::string& camera = rig.cameras().at(index);
  sim::Image img;
  std::vector<std::uint16_t> depth;
  rig.render(index, img, depth);
  const auto K = sim::camera_pinhole(m, camera, rig.width(), rig.height());
  const auto pose = sim::camera_pose(m, d, camera);
  RgbdFrame frame;
  frame.K = {K.fx, K.fy, K.cx, K.cy, K.width, K.height};
  frame.world_from_camera = Eigen::Translation3d(pose.position[0], pose.position[1], pose.position[2]) *
                            Eigen::Quaterniond(pose.wxyz[0], pose.wxyz[1], pose.wxyz[2], pose.wxyz[3]);
  frame.rgb = cv::Mat(rig.height(), rig.width(), CV_8UC3, img.rgb.data()).clone();
  frame.depth = cv::Mat(rig.height(), rig.width(), CV_16UC1, depth.data()).clone();
  return frame;
}

}  // namespace dh::perception::tools
