// A live camera's buffers as the wire wants them (dh/rgbd_camera/frame_convert.hpp): padded rows lose
// their padding and nothing else, depth units become millimetres, the pinhole of a field of view, and
// a camera's file whose intrinsics are left out or half given.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "dh/rgbd_camera/frame_convert.hpp"

namespace dh::camera {
namespace {

TEST(FrameConvert, DepthRowsLoseTheirPaddingAndKeepEveryValue) {
  constexpr int w = 3, h = 2, stride = 10;  // 6 octets of pixels, 4 of padding per row
  std::vector<std::uint8_t> buf(stride * h, 0xEE);
  const std::uint16_t values[h][w] = {{0, 1, 65535}, {1234, 999, 2}};
  for (int r = 0; r < h; ++r) std::memcpy(buf.data() + r * stride, values[r], sizeof values[r]);
  const auto mm = depth_mm(buf.data(), w, h, stride, DepthUnit::Millimetre);
  ASSERT_EQ(mm.size(), 6u);
  EXPECT_EQ(mm, (std::vector<std::uint16_t>{0, 1, 65535, 1234, 999, 2}));
}

TEST(FrameConvert, HundredMicrometreDepthRoundsToTheNearestMillimetreAndZeroStaysNoReading) {
  const std::uint16_t v[] = {0, 4, 5, 14, 15, 12345, 65535};
  const auto mm = depth_mm(v, 7, 1, sizeof v, DepthUnit::HundredMicrometre);
  EXPECT_EQ(mm, (std::vector<std::uint16_t>{0, 0, 1, 1, 2, 1235, 6554}));
}

TEST(FrameConvert, ColourRowsLoseTheirPadding) {
  constexpr int w = 2, h = 3, stride = 8;
  std::vector<std::uint8_t> buf(stride * h, 0xEE);
  for (int r = 0; r < h; ++r)
    for (int i = 0; i < 3 * w; ++i) buf[r * stride + i] = static_cast<std::uint8_t>(10 * r + i);
  const auto rgb = rgb_rows(buf.data(), w, h, stride);
  ASSERT_EQ(rgb.size(), 18u);
  for (int r = 0; r < h; ++r)
    for (int i = 0; i < 3 * w; ++i) EXPECT_EQ(rgb[r * 3 * w + i], 10 * r + i) << r << " " << i;
}

TEST(FrameConvert, RowsShorterThanTheirPixelsAreRefused) {
  std::vector<std::uint8_t> buf(64);
  EXPECT_THROW(depth_mm(buf.data(), 4, 2, 7, DepthUnit::Millimetre), std::invalid_argument);
  EXPECT_THROW(rgb_rows(buf.data(), 4, 2, 11), std::invalid_argument);
  EXPECT_THROW(rgb_rows(buf.data(), 0, 2, 11), std::invalid_argument);
}

TEST(FrameConvert, APinholeFromFieldsOfView) {
  // 90° across 640 pixels: the focal length is half the width.
  const auto K = intrinsics_from_fov(640, 480, std::numbers::pi / 2, 2 * std::atan(240.0 / 320.0));
  EXPECT_EQ(K.width, 640);
  EXPECT_EQ(K.height, 480);
  EXPECT_NEAR(K.fx, 320.0, 1e-9);
  EXPECT_NEAR(K.fy, 320.0, 1e-9);
  EXPECT_EQ(K.cx, 319.5);
  EXPECT_EQ(K.cy, 239.5);
  // 60° × 45° at 320 × 240: fx = 160 / tan 30°, fy = 120 / tan 22.5°.
  const auto K2 = intrinsics_from_fov(320, 240, std::numbers::pi / 3, std::numbers::pi / 4);
  EXPECT_NEAR(K2.fx, 277.128, 1e-3);
  EXPECT_NEAR(K2.fy, 289.706, 1e-3);
}

TEST(FrameConvert, AFieldOfViewTheDeviceDoesNotReportNamesTheFileToGive) {
  try {
    intrinsics_from_fov(320, 240, 0.0, 0.0);
    FAIL() << "a zero field of view was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--camera-file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(intrinsics_from_fov(320, 240, std::numbers::pi, 1.0), std::invalid_argument);
  EXPECT_THROW(intrinsics_from_fov(320, 240, 1.0, std::nan("")), std::invalid_argument);
}

class CameraFileTest : public ::testing::Test {
 protected:
  std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("dh_test_camera_file_" + std::to_string(getpid()) + ".yaml");
  void write(const std::string& s) { std::ofstream(file) << s; }
  void TearDown() override { std::filesystem::remove(file); }
};

TEST_F(CameraFileTest, ALiveCameraMayLeaveItsIntrinsicsToTheDevice) {
  write("camera: front\npose:\n  position: [1, 2, 3]\n  orientation: [0, 1, 0, 0]\n");
  const auto c = frames::read_camera_file(file, false);
  EXPECT_FALSE(c.has_intrinsics);
  EXPECT_EQ(c.camera, "front");
  EXPECT_TRUE(c.has_pose);
  EXPECT_EQ(c.position[2], 3.0);
  EXPECT_EQ(c.orientation[1], 1.0);
  EXPECT_THROW(frames::read_camera_file(file, true), frames::FramesError)
      << "a recording needs its intrinsics";
}

TEST_F(CameraFileTest, HalfTheIntrinsicsIsRefusedNamingTheKeyMissing) {
  write("width: 640\nheight: 480\nfx: 600\n");
  try {
    frames::read_camera_file(file, false);
    FAIL() << "half the intrinsics were taken";
  } catch (const frames::FramesError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find("fy"), std::string::npos) << what;
  }
  write("width: 640\nheight: 480\nfx: 600\nfy: 601\nppx: 320.5\nppy: 240.5\n");
  const auto c = frames::read_camera_file(file, false);
  EXPECT_TRUE(c.has_intrinsics);
  EXPECT_EQ(c.K.cx, 320.5);
}

}  // namespace
}  // namespace dh::camera
