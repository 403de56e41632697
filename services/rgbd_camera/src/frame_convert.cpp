#include "dh/rgbd_camera/frame_convert.hpp"

#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>

namespace dh::camera {

namespace {

void check(int width, int height, int stride, int bytes_per_pixel, const char* what) {
  if (width < 1 || height < 1)
    throw std::invalid_argument(std::string(what) + " buffer of " + std::to_string(width) + "x" +
                                std::to_string(height) + " pixels");
  if (stride < bytes_per_pixel * width)
    throw std::invalid_argument(std::string(what) + " rows of " + std::to_string(stride) +
                                " octets hold fewer than " + std::to_string(width) + " pixels");
}

}  // namespace

std::vector<std::uint16_t> depth_mm(const void* data, int width, int height, int stride, DepthUnit unit) {
  check(width, height, stride, 2, "depth");
  std::vector<std::uint16_t> out(static_cast<std::size_t>(width) * height);
  const auto* base = static_cast<const std::uint8_t*>(data);
  for (int r = 0; r < height; ++r) {
    std::uint16_t* dst = out.data() + static_cast<std::size_t>(r) * width;
    std::memcpy(dst, base + static_cast<std::size_t>(r) * stride, 2 * static_cast<std::size_t>(width));
    if (unit == DepthUnit::HundredMicrometre)
      for (int c = 0; c < width; ++c) dst[c] = static_cast<std::uint16_t>((dst[c] + 5) / 10);
  }
  return out;
}

std::vector<std::uint8_t> rgb_rows(const void* data, int width, int height, int stride) {
  check(width, height, stride, 3, "colour");
  const std::size_t row = 3 * static_cast<std::size_t>(width);
  std::vector<std::uint8_t> out(row * height);
  const auto* base = static_cast<const std::uint8_t*>(data);
  for (int r = 0; r < height; ++r)
    std::memcpy(out.data() + r * row, base + static_cast<std::size_t>(r) * stride, row);
  return out;
}

frames::Intrinsics intrinsics_from_fov(int width, int height, double hfov, double vfov) {
  const auto valid = [](double a) { return std::isfinite(a) && a > 0 && a < std::numbers::pi; };
  if (!valid(hfov) || !valid(vfov))
    throw std::invalid_argument(
        "the device reports fields of view of " + std::to_string(hfov) + " and " + std::to_string(vfov) +
        " rad; give width, height, fx, fy, cx and cy in the camera's file (--camera-file)");
  frames::Intrinsics K;
  K.width = width;
  K.height = height;
  K.fx = (width / 2.0) / std::tan(hfov / 2);
  K.fy = (height / 2.0) / std::tan(vfov / 2);
  K.cx = (width - 1) / 2.0;
  K.cy = (height - 1) / 2.0;
  return K;
}

}  // namespace dh::camera
