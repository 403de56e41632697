// Segmentation masks and the decoders for what an external segmentation server returns.
//
// A Mask is a binary image the size of the frame: nonzero = the entity's pixels (the decoders and the
// segmenters write 255). Decoders throw MaskDecodeError naming what is wrong.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

namespace dh::perception {

struct Mask {
  std::string entity;  ///< the entity (scene name) this mask is a candidate for
  cv::Mat1b pixels;    ///< frame-sized, nonzero = in the mask
  double score = 0;    ///< in [0, 1]; the segmenter's own confidence
};

struct MaskDecodeError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Standard base64 (RFC 4648 alphabet, '=' padding; whitespace is skipped, the unpadded form is
/// accepted). Throws MaskDecodeError on a character outside the alphabet, misplaced padding or a length
/// that cannot be base64.
std::string base64_decode(std::string_view text);
std::string base64_encode(std::string_view bytes);

/// COCO uncompressed RLE, as SAM and pycocotools write it: run lengths over the pixels in column-major
/// (Fortran) order, alternating background and foreground, starting with background (a leading 0 when
/// the first pixel is foreground). Throws MaskDecodeError when the counts do not sum to width*height or
/// the size is not positive.
cv::Mat1b decode_rle(const std::vector<std::int64_t>& counts, int width, int height);
/// The inverse of decode_rle (nonzero = foreground).
std::vector<std::int64_t> encode_rle(const cv::Mat1b& mask);

/// COCO compressed RLE (the "counts" string of pycocotools' mask.encode): the same runs, each written as
/// the difference to the run two before (from the fourth run on, as pycocotools does), in 5-bit groups
/// of 6-bit characters offset by 48. Throws
/// MaskDecodeError on a character outside '0'..'o', a truncated value, a negative run or a wrong sum.
cv::Mat1b decode_coco_rle_string(std::string_view counts, int width, int height);
std::string encode_coco_rle_string(const cv::Mat1b& mask);

/// A PNG mask in base64 (8 or 16 bits; a pixel is in the mask when its value, or for a colour PNG any
/// colour channel, is nonzero). Throws MaskDecodeError on bad base64, bytes that are not a PNG image, or a size other than
/// width x height.
cv::Mat1b decode_png_base64_mask(std::string_view base64_png, int width, int height);

}  // namespace dh::perception
