#include "dh/perception/rendered_frame.hpp"

#include <mujoco/mujoco.h>

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "dh/sim/rgbd.hpp"

namespace dh::perception {

RgbdFrame rendered_frame(sim::CameraRig& rig, std::size_t index, const mjModel_* m, const mjData_* d) {
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
  frame.stamp_s = d->time;
  return frame;
}

}  // namespace dh::perception
