// Growing a seed mask over the depth image into the rest of its object. Colour finds only some faces of
// a white or grey object: under a light from above its walls render as grey as the floor, the robot and
// the shadows. Depth tells them apart: the walls are continuous with the lit top and stand above the
// support, the table and the floor do not.
#pragma once

#include <opencv2/core.hpp>

#include "dh/perception/frame.hpp"

namespace dh::perception {

struct GrowParams {
  double support_z = 0;         ///< the support surface's height (world z, m)
  double min_height_m = 0.008;  ///< pixels up to this high above the support never join
  double max_height_m =
      1.0;  ///< pixels higher above the support are neither seed nor grown (the object's height)
  double max_radius_m = 0.1;  ///< horizontal distance from the seed's centre a pixel may have (m)
  double max_step_m = 0.01;   ///< neighbours farther apart along the optical axis are different surfaces
  double min_depth_m = 0.15, max_depth_m = 3.0;  ///< valid depth readings, as CloudParams
};

/// The seed's pixels (frame-sized, nonzero = in) with valid depth between min_height_m and max_height_m
/// above the support, plus every pixel 4-connected to them through pixels with valid depth in the same
/// band, within max_radius_m horizontally of the kept seed's mean and less than max_step_m in depth from
/// the neighbour they are reached from. A seed with no such pixel gives an empty
/// mask. Throws std::invalid_argument on a bad frame or a seed of another size.
cv::Mat1b grow_by_depth(const RgbdFrame& frame, const cv::Mat1b& seed, const GrowParams& params);

}  // namespace dh::perception
