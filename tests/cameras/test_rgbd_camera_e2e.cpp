// rgbd_camera, a real process, on a real OpenNI2 device path: OpenNI2's own test device ("Dummy", in
// Debian's libopenni2-0 beside the PS1080 driver) streams 320x240 depth and colour from its driver
// threads, and the frames are asked for over DDS as perception asks. Its pictures are known (OpenNI2's
// Source/Drivers/DummyDevice/DummyDevice.cpp): depth row 0 at 2000 mm and a disc whose pixel (x, y) is
// 1000 + 3 (x − y) mm, zero elsewhere; colour black but for pixel (0, 0)'s blue and a disc whose pixel is
// (255 x / 320, 255 y / 240, 255 (320 − x) / 320). So the test checks every pixel, not only sizes.
// It cannot register depth to colour, which is refused unless --registration none says it need not.
#include <fstream>

#include "../integration/harness.hpp"
#include "frame_requests.hpp"
#include "rgbd_pixels.hpp"

namespace dh {
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

namespace {

/// A participant of its own, asking for frames as perception does.
class Requester {
 public:
  bool wait_ready() {
    const auto end = Clock::now() + 30s;
    while (Clock::now() < end && !frames_.matched()) std::this_thread::sleep_for(20ms);
    return frames_.matched();
  }
  std::optional<msg::RgbdFrame> request(std::uint32_t channel, const std::string& camera,
                                        const std::string& id, std::chrono::milliseconds timeout = 10s) {
    return frames_.request(channel, camera, id, timeout);
  }

 private:
  dds::Participant p_{"rgbd_camera_test"};
  camtest::FrameRequests frames_{p_};
};

/// Starts rgbd_camera with `args`, waits for it to end on its own (a refusal at start) and returns its log.
std::string log_of_refused_start(const itest::IsolatedEnv& env, std::vector<std::string> args) {
  cli::Deployment cam({itest::service("rgbd_camera", std::move(args))}, paths::bin_dir(), env.runs / "logs");
  const auto t0 = Clock::now();
  std::vector<std::string> exited;
  while ((exited = cam.exited()).empty() && Clock::now() - t0 < 20s) std::this_thread::sleep_for(50ms);
  EXPECT_EQ(exited, std::vector<std::string>{"rgbd_camera"}) << "rgbd_camera kept running";
  return itest::read_text(env.runs / "logs/rgbd_camera.log");
}

TEST(RgbdCameraE2E, ALiveDeviceAnswersEachRequestWithItsPicturesPixelForPixel) {
  itest::IsolatedEnv env;
  const fs::path file = env.runs / "front.yaml";
  std::ofstream(file) << "camera: front\nwidth: 320\nheight: 240\nfx: 280.5\nfy: 281\ncx: 159.5\ncy: 119.5\n"
                         "pose:\n  position: [0.1, -0.2, 0.9]\n  orientation: [0, 1, 0, 0]\n";
  auto cam = std::make_unique<cli::Deployment>(
      std::vector<cli::ServiceSpec>{itest::service(
          "rgbd_camera",
          {"--device", "Dummy", "--camera-file", file.string(), "--registration", "none", "--channel", "4"})},
      paths::bin_dir(), env.runs / "logs");
  Requester c;
  ASSERT_TRUE(c.wait_ready()) << itest::read_text(env.runs / "logs/rgbd_camera.log");
  EXPECT_FALSE(c.request(4, "workcell", "another-camera", 1s).has_value())
      << "answered another camera's request";
  int last_index = -1;
  for (int i = 0; i < 3; ++i) {
    const auto f = c.request(4, "front", "r" + std::to_string(i));
    ASSERT_TRUE(f.has_value()) << "request " << i << ": "
                               << itest::read_text(env.runs / "logs/rgbd_camera.log");
    ASSERT_EQ(f->error(), "");
    EXPECT_EQ(f->channel(), 4u);
    EXPECT_EQ(f->source(), "rgbd_camera Dummy");
    EXPECT_GT(static_cast<int>(f->step()), last_index) << "a frame taken before the request";
    last_index = static_cast<int>(f->step());
    ASSERT_EQ(f->width(), 320u);
    ASSERT_EQ(f->height(), 240u);
    EXPECT_EQ(f->fx(), 280.5);
    EXPECT_EQ(f->cy(), 119.5);
    EXPECT_TRUE(f->has_pose());
    EXPECT_EQ(f->position()[2], 0.9);
    EXPECT_EQ(f->orientation()[1], 1.0);
    ASSERT_EQ(f->depth().size(), 320u * 240u * 2u);
    ASSERT_EQ(f->rgb().size(), 320u * 240u * 3u);
    int disc = 0;
    for (std::size_t y = 0; y < 240; ++y)
      for (std::size_t x = 0; x < 320; ++x) {
        const std::uint16_t d = camtest::depth_mm(*f, y, x);
        if (y == 0) {
          ASSERT_EQ(d, 2000) << x;
        } else if (d != 0) {
          ASSERT_EQ(d, 1000 + 3 * (static_cast<int>(x) - static_cast<int>(y))) << x << "," << y;
          ++disc;
        }
      }
    EXPECT_GT(disc, 20) << "no disc in the depth image";
    EXPECT_EQ(f->rgb()[2], 255) << "pixel (0, 0)'s blue";
    int lit = 0;
    for (std::size_t y = 0; y < 240; ++y)
      for (std::size_t x = 0; x < 320; ++x) {
        const std::uint8_t* px = f->rgb().data() + 3 * (y * 320 + x);
        if ((x == 0 && y == 0) || (px[0] == 0 && px[1] == 0 && px[2] == 0)) continue;
        ASSERT_EQ(px[0], static_cast<std::uint8_t>(255 * (x / 320.0))) << x << "," << y;
        ASSERT_EQ(px[1], static_cast<std::uint8_t>(255 * (y / 240.0))) << x << "," << y;
        ASSERT_EQ(px[2], static_cast<std::uint8_t>(255 * ((320 - x) / 320.0))) << x << "," << y;
        ++lit;
      }
    EXPECT_GT(lit, 20) << "no disc in the colour image";
  }
  EXPECT_TRUE(cam->exited().empty()) << "rgbd_camera ended";
  cam.reset();  // SIGTERM: the streams stop and OpenNI2 unloads its drivers, and the process ends cleanly
  const std::string log = itest::read_text(env.runs / "logs/rgbd_camera.log");
  EXPECT_NE(log.find("lifecycle: shutdown (inactive -> finalized)"), std::string::npos) << log;
}

TEST(RgbdCameraE2E, ADeviceThatCannotRegisterDepthToColourIsRefusedAtStart) {
  itest::IsolatedEnv env;
  const fs::path file = env.runs / "cam.yaml";
  std::ofstream(file) << "width: 320\nheight: 240\nfx: 280\nfy: 280\ncx: 159.5\ncy: 119.5\n";
  const std::string log = log_of_refused_start(env, {"--device", "Dummy", "--camera-file", file.string()});
  EXPECT_NE(log.find("cannot register depth to colour"), std::string::npos) << log;
  EXPECT_NE(log.find("--registration none"), std::string::npos) << log;
}

TEST(RgbdCameraE2E, WithoutIntrinsicsFromTheFileOrTheDeviceItSaysWhatToGive) {
  itest::IsolatedEnv env;
  const std::string log = log_of_refused_start(env, {"--device", "Dummy", "--registration", "none"});
  EXPECT_NE(log.find("fields of view"), std::string::npos) << log;
  EXPECT_NE(log.find("--camera-file"), std::string::npos) << log;
}

TEST(RgbdCameraE2E, ADeviceThatIsNotThereIsNamedWithWhatOpenNI2Sees) {
  itest::IsolatedEnv env;
  const std::string log = log_of_refused_start(env, {"--device", "usb-no-such-camera"});
  EXPECT_NE(log.find("camera usb-no-such-camera: cannot be opened"), std::string::npos) << log;
  EXPECT_NE(log.find("OpenNI2 sees"), std::string::npos) << log;
}

}  // namespace
}  // namespace dh
