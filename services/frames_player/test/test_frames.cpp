// The recorded-frames folder frames_player plays (dh/frames/recording.hpp): a valid recording reads back
// exactly (pairing, order, intrinsics and their RealSense aliases, depth scale, pose, colour order), and
// every malformed input is refused with a message naming the file at fault.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dh/frames/rate_schedule.hpp"
#include "dh/frames/recording.hpp"

namespace dh {
namespace {

namespace fs = std::filesystem;

constexpr int kW = 8, kH = 6;
const std::string kIntrinsics = "width: 8\nheight: 6\nfx: 10.5\nfy: 11\ncx: 3.5\ncy: 2.5\n";

/// A fresh recording folder under the temp directory, removed afterwards.
class Folder {
 public:
  Folder() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("dh_test_frames_" + std::to_string(getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "color");
    fs::create_directories(dir_ / "depth");
  }
  ~Folder() { fs::remove_all(dir_); }
  const fs::path& dir() const { return dir_; }
  void text(const std::string& name, const std::string& s) const { std::ofstream(dir_ / name) << s; }
  /// Frame `stem`: colour pixel (r, c) = (R, G, B) = (10 r + c, 100 + stem digit, 200), depth (r, c) = 1000 +
  /// 10 r + c.
  void frame(const std::string& stem, int w = kW, int h = kH) const {
    cv::Mat bgr(h, w, CV_8UC3), depth(h, w, CV_16UC1);
    const int k = stem.back() - '0';
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        bgr.at<cv::Vec3b>(r, c) = cv::Vec3b(200, static_cast<uchar>(100 + k), static_cast<uchar>(10 * r + c));
        depth.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(1000 + 10 * r + c);
      }
    ASSERT_TRUE(cv::imwrite((dir_ / "color" / (stem + ".png")).string(), bgr));
    ASSERT_TRUE(cv::imwrite((dir_ / "depth" / (stem + ".png")).string(), depth));
  }

 private:
  fs::path dir_;
};

/// open_recording + read_frame of every frame must fail with a message containing all of `expect`.
void expect_refused(const fs::path& dir, const std::vector<std::string>& expect) {
  try {
    const auto rec = frames::open_recording(dir);
    for (std::size_t i = 0; i < rec.frames.size(); ++i) frames::read_frame(rec, i);
    ADD_FAILURE() << "accepted " << dir;
  } catch (const frames::FramesError& e) {
    for (const auto& s : expect)
      EXPECT_NE(std::string(e.what()).find(s), std::string::npos) << e.what() << "\n  lacks: " << s;
  }
}

TEST(FramesFolder, AValidRecordingReadsBackExactly) {
  Folder f;
  f.text("intrinsics.yaml", kIntrinsics);
  f.frame("000010");
  f.frame("000002");
  f.frame("000001");
  f.text("color/notes.txt", "ignored");
  const auto rec = frames::open_recording(f.dir());
  EXPECT_EQ(rec.K.width, kW);
  EXPECT_EQ(rec.K.height, kH);
  EXPECT_EQ(rec.K.fx, 10.5);
  EXPECT_EQ(rec.K.fy, 11);
  EXPECT_EQ(rec.K.cx, 3.5);
  EXPECT_EQ(rec.K.cy, 2.5);
  EXPECT_EQ(rec.depth_scale, 0.001);
  EXPECT_EQ(rec.camera, "workcell");
  EXPECT_FALSE(rec.has_pose);
  ASSERT_EQ(rec.frames.size(), 3u);
  EXPECT_EQ(rec.frames[0].stem, "000001");  // lexicographic order
  EXPECT_EQ(rec.frames[1].stem, "000002");
  EXPECT_EQ(rec.frames[2].stem, "000010");
  const auto fr = frames::read_frame(rec, 1);
  EXPECT_EQ(fr.index, 1u);
  EXPECT_EQ(fr.stem, "000002");
  ASSERT_EQ(fr.rgb.size(), std::size_t(kW * kH * 3));
  ASSERT_EQ(fr.depth_mm.size(), std::size_t(kW * kH));
  // Pixel (row 4, column 7), row-major, top row first, R G B order.
  const std::size_t i = 4 * kW + 7;
  EXPECT_EQ(fr.rgb[3 * i], 47);
  EXPECT_EQ(fr.rgb[3 * i + 1], 102);
  EXPECT_EQ(fr.rgb[3 * i + 2], 200);
  EXPECT_EQ(fr.depth_mm[i], 1047);
  EXPECT_THROW(frames::read_frame(rec, 3), std::out_of_range);
}

TEST(FramesFolder, RealSenseKeysDepthScalePoseAndCameraName) {
  Folder f;
  f.text("intrinsics.yaml",
         "width: 8\nheight: 6\nfx: 10\nfy: 10\nppx: 3.25\nppy: 2.75\ndepth_scale: 0.0002\ncamera: d435\n"
         "pose:\n  position: [0.5, -0.1, 1.2]\n  orientation: [0, 1, 0, 0.0001]\n");
  f.frame("a0");
  const auto rec = frames::open_recording(f.dir());
  EXPECT_EQ(rec.K.cx, 3.25);
  EXPECT_EQ(rec.K.cy, 2.75);
  EXPECT_EQ(rec.camera, "d435");
  ASSERT_TRUE(rec.has_pose);
  EXPECT_EQ(rec.position, (std::array<double, 3>{0.5, -0.1, 1.2}));
  EXPECT_NEAR(rec.orientation[1], 1, 1e-6);
  const auto fr = frames::read_frame(rec, 0);
  // TUM-style depth: 5000 units per metre; raw 1047 -> 209.4 mm -> 209.
  EXPECT_EQ(fr.depth_mm[4 * kW + 7], 209);
}

TEST(FramesFolder, GreyAndRgbaColourAreAccepted) {
  Folder f;
  f.text("intrinsics.yaml", kIntrinsics);
  f.frame("0");
  cv::Mat grey(kH, kW, CV_8UC1, cv::Scalar(77)), bgra(kH, kW, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  cv::imwrite((f.dir() / "color/0.png").string(), grey);
  auto fr = frames::read_frame(frames::open_recording(f.dir()), 0);
  EXPECT_EQ(fr.rgb[0], 77);
  EXPECT_EQ(fr.rgb[2], 77);
  cv::imwrite((f.dir() / "color/0.png").string(), bgra);
  fr = frames::read_frame(frames::open_recording(f.dir()), 0);
  EXPECT_EQ(fr.rgb[0], 3);
  EXPECT_EQ(fr.rgb[1], 2);
  EXPECT_EQ(fr.rgb[2], 1);
}

TEST(FramesFolder, DepthConversionAndWireFormat) {
  EXPECT_EQ(frames::raw_depth_to_mm(0, 0.001), 0);
  EXPECT_EQ(frames::raw_depth_to_mm(1234, 0.001), 1234);
  EXPECT_EQ(frames::raw_depth_to_mm(1234, 0.0001), 123);
  EXPECT_EQ(frames::raw_depth_to_mm(40000, 0.002), 0) << "80 m does not fit: no reading";
  EXPECT_EQ(frames::depth_le_bytes({0x1234, 0xABCD}), (std::vector<std::uint8_t>{0x34, 0x12, 0xCD, 0xAB}));
}

TEST(FramesFolder, MissingPiecesAreNamed) {
  {
    const fs::path nowhere = fs::temp_directory_path() / "dh_test_frames_no_such_folder";
    expect_refused(nowhere, {nowhere.string(), "no such folder"});
  }
  {
    Folder f;
    f.text("file", "x");
    expect_refused(f.dir() / "file", {"file", "not a folder"});
  }
  {
    Folder f;
    f.frame("0");
    expect_refused(f.dir(), {(f.dir() / "intrinsics.yaml").string(), "missing"});
  }
  {
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    fs::remove_all(f.dir() / "color");
    expect_refused(f.dir(), {(f.dir() / "color").string(), "missing"});
  }
  {
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    fs::remove_all(f.dir() / "depth");
    expect_refused(f.dir(), {(f.dir() / "depth").string(), "missing"});
  }
  {
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    expect_refused(f.dir(), {(f.dir() / "color").string(), "no PNG frames"});
  }
  {
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    f.frame("1");
    fs::remove(f.dir() / "depth/1.png");
    expect_refused(f.dir(), {(f.dir() / "color/1.png").string(), "no depth image", "depth/1.png"});
  }
  {
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    f.frame("1");
    fs::remove(f.dir() / "color/0.png");
    expect_refused(f.dir(), {(f.dir() / "depth/0.png").string(), "no colour image", "color/0.png"});
  }
}

TEST(FramesFolder, MalformedIntrinsicsAreNamedWithTheirKey) {
  const std::pair<std::string, std::vector<std::string>> cases[] = {
      {"width: [8\n", {"intrinsics.yaml"}},
      {"- 1\n- 2\n", {"intrinsics.yaml", "map"}},
      {"", {"intrinsics.yaml", "map"}},
      {"height: 6\nfx: 10\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "width", "missing"}},
      {"width: 8\nheight: 6\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "fx", "missing"}},
      {"width: 8\nheight: 6\nfx: 10\nfy: 10\ncy: 2\n", {"intrinsics.yaml", "cx", "missing"}},
      {"width: eight\nheight: 6\nfx: 10\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "width", "integer"}},
      {"width: 0\nheight: 6\nfx: 10\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "width", "positive"}},
      {"width: 8\nheight: -6\nfx: 10\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "height", "positive"}},
      {"width: 8\nheight: 6\nfx: -10\nfy: 10\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "fx", "positive"}},
      {"width: 8\nheight: 6\nfx: 10\nfy: 0\ncx: 3\ncy: 2\n", {"intrinsics.yaml", "fy", "positive"}},
      {"width: 8\nheight: 6\nfx: 10\nfy: 10\ncx: 3\nppx: 3\ncy: 2\n", {"intrinsics.yaml", "cx", "twice"}},
      {kIntrinsics + "depth_scale: 0\n", {"intrinsics.yaml", "depth_scale", "positive"}},
      {kIntrinsics + "camera: ''\n", {"intrinsics.yaml", "camera", "empty"}},
      {kIntrinsics + "pose: {orientation: [1, 0, 0, 0]}\n", {"intrinsics.yaml", "pose.position", "missing"}},
      {kIntrinsics + "pose: {position: [1, 2], orientation: [1, 0, 0, 0]}\n",
       {"intrinsics.yaml", "pose.position", "3 numbers"}},
      {kIntrinsics + "pose: {position: [1, 2, 3]}\n", {"intrinsics.yaml", "pose.orientation", "missing"}},
      {kIntrinsics + "pose: {position: [1, 2, 3], orientation: [1, 0, 0]}\n",
       {"intrinsics.yaml", "pose.orientation", "4 numbers"}},
      {kIntrinsics + "pose: {position: [1, 2, 3], orientation: [1, 1, 0, 0]}\n",
       {"intrinsics.yaml", "pose.orientation", "unit quaternion"}},
  };
  for (const auto& [yaml, expect] : cases) {
    Folder f;
    f.text("intrinsics.yaml", yaml);
    f.frame("0");
    SCOPED_TRACE(yaml);
    expect_refused(f.dir(), expect);
  }
}

TEST(FramesFolder, BadImagesAreNamed) {
  {  // not a PNG at all
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    f.text("color/0.png", "this is no PNG");
    expect_refused(f.dir(), {(f.dir() / "color/0.png").string(), "cannot be decoded"});
  }
  {  // a truncated depth PNG
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    fs::resize_file(f.dir() / "depth/0.png", 20);
    expect_refused(f.dir(), {(f.dir() / "depth/0.png").string(), "cannot be decoded"});
  }
  {  // colour of the wrong size
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    cv::imwrite((f.dir() / "color/0.png").string(), cv::Mat(kH, kW + 1, CV_8UC3, cv::Scalar(0)));
    expect_refused(f.dir(), {(f.dir() / "color/0.png").string(), "9x6", "8x6"});
  }
  {  // depth of the wrong size
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    cv::imwrite((f.dir() / "depth/0.png").string(), cv::Mat(kH - 1, kW, CV_16UC1, cv::Scalar(0)));
    expect_refused(f.dir(), {(f.dir() / "depth/0.png").string(), "8x5"});
  }
  {  // 16-bit colour
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    cv::imwrite((f.dir() / "color/0.png").string(), cv::Mat(kH, kW, CV_16UC3, cv::Scalar(0)));
    expect_refused(f.dir(), {(f.dir() / "color/0.png").string(), "8 bits", "16-bit"});
  }
  {  // 8-bit depth (a visualisation, not the raw depth)
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    cv::imwrite((f.dir() / "depth/0.png").string(), cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0)));
    expect_refused(f.dir(), {(f.dir() / "depth/0.png").string(), "16-bit single-channel", "8-bit 1-channel"});
  }
  {  // colourised 16-bit depth
    Folder f;
    f.text("intrinsics.yaml", kIntrinsics);
    f.frame("0");
    cv::imwrite((f.dir() / "depth/0.png").string(), cv::Mat(kH, kW, CV_16UC3, cv::Scalar(0)));
    expect_refused(f.dir(), {(f.dir() / "depth/0.png").string(), "16-bit 3-channel"});
  }
}

TEST(RateSchedule, AFrameEveryPeriodWaitsNoLongerThanTheNextAndNeverBursts) {
  using namespace std::chrono_literals;
  const auto t0 = frames::RateSchedule::Clock::time_point{} + 1h;
  frames::RateSchedule off(0);
  off.start(t0);
  EXPECT_FALSE(off.due(t0 + 10s));
  EXPECT_EQ(off.wait(t0, 100ms), 100ms);
  frames::RateSchedule r(20);  // every 50 ms
  r.start(t0);
  EXPECT_EQ(r.wait(t0, 100ms), 50ms);
  EXPECT_EQ(r.wait(t0 + 30ms, 10ms), 10ms);
  EXPECT_FALSE(r.due(t0 + 49ms));
  EXPECT_TRUE(r.due(t0 + 50ms));
  EXPECT_FALSE(r.due(t0 + 60ms));
  EXPECT_EQ(r.wait(t0 + 60ms, 100ms), 40ms);
  // Three periods late: one frame, and the next a period from now, not three at once.
  EXPECT_TRUE(r.due(t0 + 250ms));
  EXPECT_FALSE(r.due(t0 + 251ms));
  EXPECT_TRUE(r.due(t0 + 300ms));
  EXPECT_EQ(r.wait(t0 + 400ms, 100ms), 0ms);
}

}  // namespace
}  // namespace dh
