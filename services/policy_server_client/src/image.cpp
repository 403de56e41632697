#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/policy/resize_with_pad.hpp"

namespace dh::policy {

namespace {

// Filter weights in fixed point with this many fraction bits, results rounded to 8 bits after each pass
// (PIL's resampling arithmetic for 8-bit images).
constexpr int kFractionBits = 22;

// The input samples that make one output sample along one axis, and their weights.
struct Taps {
  int first = 0;
  std::vector<std::int64_t> weights;
};

double triangle(double x) {
  x = std::abs(x);
  return x < 1.0 ? 1.0 - x : 0.0;
}

// Output sample i covers input [i·scale, (i+1)·scale); the triangle filter is stretched by the scale when
// shrinking (so every input sample contributes), and by 1 when enlarging (plain linear interpolation).
std::vector<Taps> taps_for(int in_size, int out_size) {
  const double scale = double(in_size) / out_size;
  const double stretch = std::max(scale, 1.0);
  const double support = stretch;  // the triangle's half-width is 1
  std::vector<Taps> taps(out_size);
  for (int i = 0; i < out_size; ++i) {
    const double centre = (i + 0.5) * scale;
    const int lo = std::max(static_cast<int>(centre - support + 0.5), 0);
    const int hi = std::min(static_cast<int>(centre + support + 0.5), in_size);
    std::vector<double> w;
    double sum = 0;
    for (int x = lo; x < hi; ++x) {
      w.push_back(triangle((x - centre + 0.5) / stretch));
      sum += w.back();
    }
    taps[i].first = lo;
    for (const double v : w) {
      const double k = sum != 0 ? v / sum : 0.0;
      taps[i].weights.push_back(static_cast<std::int64_t>(std::lround(k * (1 << kFractionBits))));
    }
  }
  return taps;
}

std::uint8_t to_byte(std::int64_t acc) {
  const std::int64_t v = (acc + (std::int64_t(1) << (kFractionBits - 1))) >> kFractionBits;
  return static_cast<std::uint8_t>(std::clamp<std::int64_t>(v, 0, 255));
}

// Resamples rows (horizontal) of an RGB image from `w` to `out_w` columns.
std::vector<std::uint8_t> resample_rows(const std::vector<std::uint8_t>& in, int w, int h, int out_w) {
  if (out_w == w) return in;
  const auto taps = taps_for(w, out_w);
  std::vector<std::uint8_t> out(std::size_t(out_w) * h * 3);
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* row = in.data() + std::size_t(y) * w * 3;
    for (int x = 0; x < out_w; ++x) {
      for (int c = 0; c < 3; ++c) {
        std::int64_t acc = 0;
        for (std::size_t k = 0; k < taps[x].weights.size(); ++k)
          acc += taps[x].weights[k] * row[(taps[x].first + k) * 3 + c];
        out[(std::size_t(y) * out_w + x) * 3 + c] = to_byte(acc);
      }
    }
  }
  return out;
}

// Resamples columns (vertical) of an RGB image from `h` to `out_h` rows.
std::vector<std::uint8_t> resample_columns(const std::vector<std::uint8_t>& in, int w, int h, int out_h) {
  if (out_h == h) return in;
  const auto taps = taps_for(h, out_h);
  const std::size_t stride = std::size_t(w) * 3;
  std::vector<std::uint8_t> out(std::size_t(out_h) * stride);
  for (int y = 0; y < out_h; ++y) {
    for (std::size_t i = 0; i < stride; ++i) {
      std::int64_t acc = 0;
      for (std::size_t k = 0; k < taps[y].weights.size(); ++k)
        acc += taps[y].weights[k] * in[(taps[y].first + k) * stride + i];
      out[y * stride + i] = to_byte(acc);
    }
  }
  return out;
}

}  // namespace

CameraImage resize_with_pad(const CameraImage& image, int width, int height) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("resize_with_pad: target " + std::to_string(width) + " × " +
                                std::to_string(height) + " is not a size");
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != std::size_t(image.width) * std::size_t(image.height) * 3)
    throw std::invalid_argument("resize_with_pad: image '" + image.name + "' (" +
                                std::to_string(image.width) + " × " + std::to_string(image.height) + ", " +
                                std::to_string(image.rgb.size()) +
                                " bytes) is not a width × height × 3 RGB image");
  if (image.width == width && image.height == height) return image;

  // The same arithmetic as openpi's client, so that the sizes agree to the pixel.
  const double ratio = std::max(double(image.width) / width, double(image.height) / height);
  const int fit_w = std::max(1, static_cast<int>(image.width / ratio));
  const int fit_h = std::max(1, static_cast<int>(image.height / ratio));
  const auto scaled = resample_columns(resample_rows(image.rgb, image.width, image.height, fit_w), fit_w,
                                       image.height, fit_h);

  CameraImage out;
  out.name = image.name;
  out.width = width;
  out.height = height;
  out.rgb.assign(std::size_t(width) * height * 3, 0);
  const int pad_x = std::max(0, (width - fit_w) / 2);
  const int pad_y = std::max(0, (height - fit_h) / 2);
  for (int y = 0; y < fit_h && y + pad_y < height; ++y) {
    const int n = std::min(fit_w, width - pad_x);
    std::copy_n(scaled.begin() + std::ptrdiff_t(y) * fit_w * 3, std::size_t(n) * 3,
                out.rgb.begin() + (std::ptrdiff_t(y + pad_y) * width + pad_x) * 3);
  }
  return out;
}

}  // namespace dh::policy
