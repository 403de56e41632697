// Back-projection shared by back_project() (plain points) and estimate_entity() (PCL cloud): the mask
// (eroded as asked) over its bounding box, each pixel with a valid depth to the world frame.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "dh/perception/estimate.hpp"

namespace dh::perception::detail {

struct PixelCounts {
  std::size_t mask_px = 0, valid_px = 0;
};

/// Calls emit(Eigen::Vector3d world_point) for every valid pixel of the mask, row by row.
template <class Emit>
PixelCounts back_project_each(const RgbdFrame& frame, const cv::Mat1b& mask, const CloudParams& params,
                              Emit&& emit) {
  validate(frame);
  if (mask.empty() || mask.cols != frame.depth.cols || mask.rows != frame.depth.rows)
    throw std::invalid_argument("back-projection: the mask is " + std::to_string(mask.cols) + "x" +
                                std::to_string(mask.rows) + ", the depth image " +
                                std::to_string(frame.depth.cols) + "x" + std::to_string(frame.depth.rows));
  PixelCounts counts;
  const cv::Rect box = cv::boundingRect(mask);
  if (box.area() == 0) return counts;
  cv::Mat1b m = mask(box);
  if (params.mask_erode_px > 0) {
    // Pad with zeros so pixels on the box's border erode as they would in the whole image.
    const int r = params.mask_erode_px;
    cv::Mat1b padded;
    cv::copyMakeBorder(m, padded, r, r, r, r, cv::BORDER_CONSTANT, 0);
    cv::erode(padded, padded, cv::getStructuringElement(cv::MORPH_RECT, {2 * r + 1, 2 * r + 1}));
    m = padded(cv::Rect(r, r, box.width, box.height));
  }
  const double min_mm = params.min_depth_m * 1000.0, max_mm = params.max_depth_m * 1000.0;
  const double fx = frame.K.fx, fy = frame.K.fy, cx = frame.K.cx, cy = frame.K.cy;
  const Eigen::Matrix3d R = frame.world_from_camera.linear();
  const Eigen::Vector3d t = frame.world_from_camera.translation();
  for (int y = 0; y < box.height; ++y) {
    const unsigned char* mp = m.ptr<unsigned char>(y);
    const int v = box.y + y;
    const std::uint16_t* dp = frame.depth.ptr<std::uint16_t>(v) + box.x;
    const double ray_y = (v - cy) / fy;
    for (int x = 0; x < box.width; ++x) {
      if (!mp[x]) continue;
      ++counts.mask_px;
      const double d = dp[x];
      if (d <= 0 || d < min_mm || d > max_mm) continue;
      ++counts.valid_px;
      const double z = d * 0.001;
      const Eigen::Vector3d p_cam(((box.x + x) - cx) / fx * z, ray_y * z, z);
      emit(Eigen::Vector3d(R * p_cam + t));
    }
  }
  return counts;
}

}  // namespace dh::perception::detail
