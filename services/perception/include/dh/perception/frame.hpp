// One RGB-D frame as the perception library takes it: pinhole intrinsics, the camera's pose in the world,
// the colour image and the depth image registered to it (same size, same pixel grid).
//
// Conventions: the camera frame is OpenCV's pinhole frame (x right, y down, z forward along the optical
// axis); the world is z up, metres. Pixel (u, v) integer coordinates are pixel centres: the ray through
// pixel (u, v) is ((u - cx) / fx, (v - cy) / fy, 1) in the camera frame.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace dh::perception {

struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
};

struct RgbdFrame {
  Intrinsics K;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  cv::Mat rgb;    ///< CV_8UC3, RGB channel order (not OpenCV's usual BGR)
  cv::Mat depth;  ///< CV_16UC1, millimetres along the optical axis (z), 0 = no reading (RealSense convention)
  double stamp_s = 0;
};

/// Throws std::invalid_argument naming what is wrong: non-positive focal lengths or size, an image whose
/// size differs from K's, a colour image that is not CV_8UC3 or a depth image that is not CV_16UC1.
/// An empty rgb is allowed (estimation needs only depth).
void validate(const RgbdFrame& frame);

}  // namespace dh::perception
