// Resize with padding, as openpi's client does before it sends an image (openpi_client.image_tools,
// after tf.image.resize_with_pad): scale to fit inside the target keeping the aspect ratio, then centre on
// black. Plain C++, no image library.
#pragma once

#include "dh/policy/openpi_types.hpp"

namespace dh::policy {

/// `image` scaled by one factor so that it fits `width` × `height` (one side fills it), centred, the rest
/// black. The scaling follows PIL's bilinear resampling, which openpi uses: a triangle filter widened by
/// the scale factor when shrinking, the horizontal pass first, 8-bit results after each pass. An image
/// already of the target size is returned unchanged. std::invalid_argument when `image` is empty, its
/// byte count is not width × height × 3, or the target is not positive.
CameraImage resize_with_pad(const CameraImage& image, int width = kOpenpiImageSide,
                            int height = kOpenpiImageSide);

}  // namespace dh::policy
