#include "dh/perception/grow.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace dh::perception {

cv::Mat1b grow_by_depth(const RgbdFrame& frame, const cv::Mat1b& seed, const GrowParams& params) {
  validate(frame);
  if (seed.cols != frame.depth.cols || seed.rows != frame.depth.rows)
    throw std::invalid_argument("grow_by_depth: the seed is " + std::to_string(seed.cols) + "x" +
                                std::to_string(seed.rows) + ", the depth image " +
                                std::to_string(frame.depth.cols) + "x" + std::to_string(frame.depth.rows));
  const double min_mm = params.min_depth_m * 1000.0, max_mm = params.max_depth_m * 1000.0;
  const Eigen::Matrix3d R = frame.world_from_camera.linear();
  const Eigen::Vector3d t = frame.world_from_camera.translation();
  const auto depth_mm = [&](int u, int v) -> double {
    const double d = frame.depth.at<std::uint16_t>(v, u);
    return d >= min_mm && d <= max_mm && d > 0 ? d : 0;
  };
  const auto world = [&](int u, int v, double d_mm) {
    const double z = d_mm * 0.001;
    return Eigen::Vector3d(
        R * Eigen::Vector3d((u - frame.K.cx) / frame.K.fx * z, (v - frame.K.cy) / frame.K.fy * z, z) + t);
  };

  const double min_z = params.support_z + params.min_height_m, max_z = params.support_z + params.max_height_m;
  std::vector<cv::Point> queue;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  cv::Mat1b out(seed.size(), 0);
  const cv::Rect box = cv::boundingRect(seed);
  for (int v = box.y; v < box.y + box.height; ++v)
    for (int u = box.x; u < box.x + box.width; ++u)
      if (seed(v, u))
        if (const double d = depth_mm(u, v); d > 0) {
          const Eigen::Vector3d w = world(u, v, d);
          if (w.z() <= min_z || w.z() > max_z) continue;
          centre += w.head<2>();
          queue.emplace_back(u, v);
          out(v, u) = 255;
        }
  if (queue.empty()) return out;
  centre /= static_cast<double>(queue.size());

  const double max_r2 = params.max_radius_m * params.max_radius_m, step_mm = params.max_step_m * 1000.0;
  constexpr int kDu[4] = {1, -1, 0, 0}, kDv[4] = {0, 0, 1, -1};
  for (std::size_t i = 0; i < queue.size(); ++i) {
    const cv::Point p = queue[i];
    const double d = depth_mm(p.x, p.y);
    for (int k = 0; k < 4; ++k) {
      const int u = p.x + kDu[k], v = p.y + kDv[k];
      if (u < 0 || v < 0 || u >= out.cols || v >= out.rows || out(v, u)) continue;
      const double dn = depth_mm(u, v);
      if (dn <= 0 || std::abs(dn - d) > step_mm) continue;
      const Eigen::Vector3d w = world(u, v, dn);
      if (w.z() <= min_z || w.z() > max_z || (w.head<2>() - centre).squaredNorm() > max_r2) continue;
      out(v, u) = 255;
      queue.emplace_back(u, v);
    }
  }
  return out;
}

}  // namespace dh::perception
