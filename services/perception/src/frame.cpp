#include "dh/perception/frame.hpp"

#include <stdexcept>
#include <string>

namespace dh::perception {

namespace {
std::string size_text(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }
}  // namespace

void validate(const RgbdFrame& frame) {
  const Intrinsics& K = frame.K;
  if (!(K.fx > 0) || !(K.fy > 0)) throw std::invalid_argument("frame: focal lengths must be positive");
  if (K.width <= 0 || K.height <= 0) throw std::invalid_argument("frame: intrinsics size must be positive");
  const std::string want = std::to_string(K.width) + "x" + std::to_string(K.height);
  if (frame.depth.empty()) throw std::invalid_argument("frame: no depth image");
  if (frame.depth.type() != CV_16UC1)
    throw std::invalid_argument("frame: depth must be CV_16UC1 (millimetres), got type " +
                                std::to_string(frame.depth.type()));
  if (frame.depth.cols != K.width || frame.depth.rows != K.height)
    throw std::invalid_argument("frame: depth is " + size_text(frame.depth) + ", intrinsics say " + want);
  if (!frame.rgb.empty()) {
    if (frame.rgb.type() != CV_8UC3)
      throw std::invalid_argument("frame: rgb must be CV_8UC3, got type " + std::to_string(frame.rgb.type()));
    if (frame.rgb.cols != K.width || frame.rgb.rows != K.height)
      throw std::invalid_argument("frame: rgb is " + size_text(frame.rgb) + ", intrinsics say " + want);
  }
}

}  // namespace dh::perception
