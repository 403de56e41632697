// What a segmentation backend is: colour image in, candidate masks per entity out. Both backends
// (ColourSegmenter, the embedded default, and HttpSegmenter, an external SAM-style server) implement it,
// so the node picks one from its configuration and calls it the same way.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dh/perception/masks.hpp"

namespace dh::perception {

/// What the scene description says an entity looks like.
struct EntityAppearance {
  std::string entity;
  /// The colours of its visible parts (material colours, RGB), the main part first. Backends that
  /// prompt by name (HttpSegmenter) ignore them.
  std::vector<cv::Vec3b> rgb;
  double min_area_px = 50;  ///< smaller candidates are dropped
  double max_area_px = 0;   ///< larger candidates are dropped; 0 = no limit
};

class Segmenter {
 public:
  virtual ~Segmenter() = default;
  /// `rgb`: CV_8UC3 in RGB order. Returns every candidate mask, frame-sized, for the entities asked
  /// (an entity may get none, or several when the backend cannot tell them apart); never masks for an
  /// entity not asked. Throws std::invalid_argument on a bad image, backends' own errors otherwise.
  virtual std::vector<Mask> segment(const cv::Mat& rgb, const std::vector<EntityAppearance>& entities) = 0;
};

}  // namespace dh::perception
