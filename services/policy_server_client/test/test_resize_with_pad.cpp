// resize_with_pad: openpi's geometry (fit, centre, black padding) and PIL's bilinear arithmetic on cases
// small enough to work out by hand.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "dh/policy/resize_with_pad.hpp"

using namespace dh::policy;

namespace {

CameraImage grey(int w, int h, std::vector<std::uint8_t> values) {
  CameraImage im{"test", w, h, {}};
  for (const auto v : values) im.rgb.insert(im.rgb.end(), {v, v, v});
  return im;
}

CameraImage uniform(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  CameraImage im{"uniform", w, h, {}};
  for (int i = 0; i < w * h; ++i) im.rgb.insert(im.rgb.end(), {r, g, b});
  return im;
}

std::uint8_t at(const CameraImage& im, int x, int y, int c = 0) { return im.rgb[(y * im.width + x) * 3 + c]; }

}  // namespace

TEST(ResizeWithPad, TargetSizeIsReturnedUnchanged) {
  auto im = uniform(224, 224, 1, 2, 3);
  im.rgb[17] = 200;
  const auto out = resize_with_pad(im);
  EXPECT_EQ(out.width, 224);
  EXPECT_EQ(out.height, 224);
  EXPECT_EQ(out.rgb, im.rgb);
}

TEST(ResizeWithPad, SquareShrinkKeepsAUniformImageUniform) {
  // openpi renders LIBERO at 256 and resizes to 224: no padding, colours kept.
  const auto out = resize_with_pad(uniform(256, 256, 10, 128, 250));
  ASSERT_EQ(out.width, 224);
  ASSERT_EQ(out.height, 224);
  ASSERT_EQ(out.rgb.size(), 224u * 224u * 3u);
  for (int y = 0; y < 224; y += 37)
    for (int x = 0; x < 224; x += 41) {
      EXPECT_EQ(at(out, x, y, 0), 10);
      EXPECT_EQ(at(out, x, y, 1), 128);
      EXPECT_EQ(at(out, x, y, 2), 250);
    }
}

TEST(ResizeWithPad, WideImageIsCentredBetweenBlackBands) {
  // 448 × 224 → fits as 224 × 112, padded by 56 rows above and below.
  const auto out = resize_with_pad(uniform(448, 224, 200, 100, 50));
  ASSERT_EQ(out.width, 224);
  ASSERT_EQ(out.height, 224);
  for (int x = 0; x < 224; x += 13) {
    EXPECT_EQ(at(out, x, 0), 0);
    EXPECT_EQ(at(out, x, 55), 0);
    EXPECT_EQ(at(out, x, 56), 200);
    EXPECT_EQ(at(out, x, 167, 2), 50);
    EXPECT_EQ(at(out, x, 168), 0);
    EXPECT_EQ(at(out, x, 223), 0);
  }
}

TEST(ResizeWithPad, TallImageIsCentredBetweenBlackColumns) {
  // 100 × 300 → ratio 300/224: fits as int(100/1.339…) = 74 columns, padding int(150/2) = 75 on the left.
  const auto out = resize_with_pad(uniform(100, 300, 90, 90, 90));
  for (int y = 0; y < 224; y += 17) {
    EXPECT_EQ(at(out, 74, y), 0);
    EXPECT_EQ(at(out, 75, y), 90);
    EXPECT_EQ(at(out, 148, y), 90);
    EXPECT_EQ(at(out, 149, y), 0);
  }
}

TEST(ResizeWithPad, HalvingUsesTheWidenedTriangleFilter) {
  // 4 × 2 → 2 × 1 (no padding). Horizontally, scale 2: output 0 weighs inputs 0, 1, 2 by 3:3:1 and output
  // 1 inputs 1, 2, 3 by 1:3:3 (the triangle widened to ±2, cut at the border); the result is rounded to 8
  // bits, then the two rows are averaged.
  //   row 0: (0·3 + 100·3 + 200) / 7 = 71.4 → 71;   (100 + 200·3 + 250·3) / 7 = 207.1 → 207
  //   row 1: (20·3 + 120·3 + 220) / 7 = 91.4 → 91;  (120 + 220·3 + 250·3) / 7 = 218.6 → 219
  //   columns: (71 + 91) / 2 = 81, (207 + 219) / 2 = 213
  const auto out = resize_with_pad(grey(4, 2, {0, 100, 200, 250, 20, 120, 220, 250}), 2, 1);
  ASSERT_EQ(out.width, 2);
  ASSERT_EQ(out.height, 1);
  EXPECT_EQ(at(out, 0, 0), 81);
  EXPECT_EQ(at(out, 1, 0), 213);
  EXPECT_EQ(at(out, 1, 0, 2), 213);
}

TEST(ResizeWithPad, EnlargingInterpolatesLinearly) {
  // 2 × 1 → 4 × 2: scale 0.5, plain linear interpolation between the two samples, edges clamped.
  const auto out = resize_with_pad(grey(2, 1, {0, 200}), 4, 2);
  EXPECT_EQ(at(out, 0, 0), 0);
  EXPECT_EQ(at(out, 1, 0), 50);
  EXPECT_EQ(at(out, 2, 0), 150);
  EXPECT_EQ(at(out, 3, 0), 200);
  EXPECT_EQ(at(out, 2, 1), 150);
}

TEST(ResizeWithPad, RefusesInconsistentImages) {
  auto im = uniform(10, 10, 1, 1, 1);
  im.rgb.pop_back();
  EXPECT_THROW(resize_with_pad(im), std::invalid_argument);
  EXPECT_THROW(resize_with_pad(CameraImage{}), std::invalid_argument);
  EXPECT_THROW(resize_with_pad(uniform(4, 4, 0, 0, 0), 0, 4), std::invalid_argument);
}
