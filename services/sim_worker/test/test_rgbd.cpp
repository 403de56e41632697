// The RGB-D workcell camera (dh/sim/rgbd.hpp): pinhole intrinsics from MuJoCo's fovy, poses in OpenCV's
// camera convention, metric depth from MuJoCo's non-linear depth buffer, configs/cameras.yaml, and
// rendered frames checked against known geometry: a constructed scene (a box on a plane) where every
// number is known, and the goal kitchen, where the table top must come out at z = 0 and every entity's
// top face at its projected pixel with its own colour. Images are saved for a person to look at in
// $DH_CAMERA_PNG_DIR (default: <temp>/dh_test_cameras): <name>_rgb.png and <name>_depth.png (16-bit mm).
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

namespace fs = std::filesystem;
using Vec3 = std::array<double, 3>;

fs::path png_dir() {
  const char* v = std::getenv("DH_CAMERA_PNG_DIR");
  const fs::path dir = v && *v ? v : fs::temp_directory_path() / "dh_test_cameras";
  fs::create_directories(dir);
  return dir;
}

void save(const sim::Image& img, const std::vector<std::uint16_t>& depth, const std::string& name) {
  cv::Mat rgb(img.height, img.width, CV_8UC3, const_cast<std::uint8_t*>(img.rgb.data())), bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  cv::imwrite((png_dir() / (name + "_rgb.png")).string(), bgr);
  cv::Mat d(img.height, img.width, CV_16UC1, const_cast<std::uint16_t*>(depth.data()));
  cv::imwrite((png_dir() / (name + "_depth.png")).string(), d);
}

fs::path temp_file(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("dh_test_rgbd_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / name) << text;
  return dir / name;
}

// ---- intrinsics and poses ------------------------------------------------------------------------------

TEST(RgbdMath, IntrinsicsFollowMuJoCosFovyAndTheImageSize) {
  const auto K = sim::pinhole_from_fovy(45, 640, 480);
  EXPECT_EQ(K.width, 640);
  EXPECT_EQ(K.height, 480);
  EXPECT_NEAR(K.fy, 240 / std::tan(22.5 * M_PI / 180), 1e-9);
  EXPECT_NEAR(K.fy, 579.411254, 1e-5);
  EXPECT_DOUBLE_EQ(K.fx, K.fy);   // square pixels
  EXPECT_DOUBLE_EQ(K.cx, 319.5);  // the optical axis between the two middle pixel centres
  EXPECT_DOUBLE_EQ(K.cy, 239.5);
  const auto S = sim::pinhole_from_fovy(90, 3, 5);
  EXPECT_NEAR(S.fy, 2.5, 1e-12);
  EXPECT_DOUBLE_EQ(S.cx, 1);
  EXPECT_DOUBLE_EQ(S.cy, 2);
  EXPECT_THROW(sim::pinhole_from_fovy(0, 640, 480), std::invalid_argument);
  EXPECT_THROW(sim::pinhole_from_fovy(180, 640, 480), std::invalid_argument);
  EXPECT_THROW(sim::pinhole_from_fovy(45, 0, 480), std::invalid_argument);
}

TEST(RgbdMath, AMuJoCoCameraLookingDownIsAnOpenCvCameraTurnedHalfwayAboutX) {
  // MuJoCo's camera axes = the world's: it looks along -z (down), its image up is +y.
  const double xpos[3] = {0.1, 0.2, 1.5};
  const double xmat[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const auto pose = sim::opencv_pose_from_mujoco(xpos, xmat);
  EXPECT_EQ(pose.position, (Vec3{0.1, 0.2, 1.5}));
  EXPECT_NEAR(std::abs(pose.wxyz[1]), 1, 1e-12);  // 180 degrees about x
  EXPECT_NEAR(pose.wxyz[0], 0, 1e-12);
  const auto R = sim::rotation_matrix(pose.wxyz);
  const double expected[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1};  // OpenCV z forward = world -z, y down = world -y
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(R[i], expected[i], 1e-12) << i;
  const auto K = sim::pinhole_from_fovy(60, 640, 480);
  // Straight below: the image centre, 1.5 m deep.
  auto p = sim::project(K, pose, {0.1, 0.2, 0});
  EXPECT_NEAR(p.u, K.cx, 1e-9);
  EXPECT_NEAR(p.v, K.cy, 1e-9);
  EXPECT_NEAR(p.z, 1.5, 1e-12);
  // +x in the world is right in the image, +y in the world is up in the image (MuJoCo's y is image up).
  p = sim::project(K, pose, {0.4, 0.2, 0});
  EXPECT_GT(p.u, K.cx + 10);
  EXPECT_NEAR(p.v, K.cy, 1e-9);
  p = sim::project(K, pose, {0.1, 0.5, 0});
  EXPECT_LT(p.v, K.cy - 10);
}

TEST(RgbdMath, ProjectionAndBackProjectionAreInverse) {
  const double xpos[3] = {0.75, 0, 1.35};
  // A look-at rotation with the world's z up in the image (columns: x right, y up, z backwards).
  const Vec3 f0{-0.9, 0, -1.35};
  const double nf = std::hypot(f0[0], f0[1], f0[2]);
  const Vec3 f{f0[0] / nf, f0[1] / nf, f0[2] / nf}, x{0, 1, 0};
  const Vec3 y{x[1] * f[2] - x[2] * f[1], x[2] * f[0] - x[0] * f[2], x[0] * f[1] - x[1] * f[0]};
  const double xmat[9] = {x[0], y[0], -f[0], x[1], y[1], -f[1], x[2], y[2], -f[2]};
  const auto pose = sim::opencv_pose_from_mujoco(xpos, xmat);
  EXPECT_GE(pose.wxyz[0], 0);
  const auto K = sim::pinhole_from_fovy(45, 640, 480);
  for (const Vec3& w : {Vec3{-0.15, 0, 0}, Vec3{0.2, -0.3, 0.1}, Vec3{-0.4, 0.5, 0.02}}) {
    const auto p = sim::project(K, pose, w);
    const auto back = sim::back_project(K, pose, p.u, p.v, p.z);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], w[i], 1e-12);
  }
  // The look-at point is on the optical axis.
  const auto c = sim::project(K, pose, {-0.15, 0, 0});
  EXPECT_NEAR(c.u, K.cx, 1e-9);
  EXPECT_NEAR(c.v, K.cy, 1e-9);
  EXPECT_NEAR(c.z, nf * (0.9 / 0.9), 1e-9);
  // Higher in the world is higher in the image (smaller v).
  EXPECT_LT(sim::project(K, pose, {-0.15, 0, 0.2}).v, c.v);
}

// ---- depth ---------------------------------------------------------------------------------------------

/// OpenGL's window depth of a point `z` m in front of a camera with clip planes n, f (glFrustum, depth range
/// 0..1).
double window_depth(double z, double n, double f) {
  const double ndc = (f + n) / (f - n) - 2 * f * n / ((f - n) * z);
  return (ndc + 1) / 2;
}

TEST(RgbdDepth, MuJoCosDepthBufferLinearisesWithTheClipPlanes) {
  const double n = 0.04, f = 200;  // e.g. znear 0.01 and zfar 50 times an extent of 4 m
  EXPECT_NEAR(sim::linear_depth(0, n, f), n, 1e-12);
  EXPECT_NEAR(sim::linear_depth(1, n, f), f, 1e-9);
  for (double z : {0.05, 0.3, 1.0, 1.62, 2.5, 10.0}) {
    EXPECT_NEAR(sim::linear_depth(window_depth(z, n, f), n, f), z, 1e-9 * z * z) << z;
    // through a float, as glReadPixels gives it: still well under a millimetre at workcell range
    const float d = static_cast<float>(window_depth(z, n, f));
    EXPECT_NEAR(sim::linear_depth(d, n, f), z, z < 3 ? 5e-4 : 1e-2) << z;
  }
  EXPECT_EQ(sim::depth_to_mm(static_cast<float>(window_depth(1.2345, n, f)), n, f), 1235);  // rounded mm
  EXPECT_EQ(sim::depth_to_mm(1.0f, n, f), 0) << "the cleared far plane is no reading";
  EXPECT_EQ(sim::depth_to_mm(std::nanf(""), n, f), 0);
  EXPECT_EQ(sim::depth_to_mm(static_cast<float>(window_depth(80, n, f)), n, f), 0) << "beyond 65.535 m";
}

TEST(RgbdDepth, TheDepthBufferIsTurnedTopRowFirst) {
  const double n = 0.1, f = 10;
  // 2 x 3, bottom row first: row 0 (bottom) at 1 m, row 2 (top) at 3 m, the last pixel empty.
  std::vector<float> buf;
  for (double z : {1.0, 1.0, 2.0, 2.0, 3.0, -1.0})
    buf.push_back(z < 0 ? 1.0f : static_cast<float>(window_depth(z, n, f)));
  std::vector<std::uint16_t> mm(6);
  sim::depth_buffer_to_mm(buf.data(), 2, 3, n, f, mm.data());
  EXPECT_EQ(mm, (std::vector<std::uint16_t>{3000, 0, 2000, 2000, 1000, 1000}));
}

// ---- configs/cameras.yaml --------------------------------------------------------------------------------

TEST(RgbdConfig, TheRepositorysWorkcellAndFrontCameras) {
  const auto c = sim::load_cameras_config(paths::config_dir() / "cameras.yaml");
  ASSERT_EQ(c.cameras.size(), 2u);
  EXPECT_TRUE(c.has(sim::kWorkcellRgbdCamera));
  EXPECT_TRUE(c.has("front"));
  EXPECT_FALSE(c.has("agentview"));
  const auto cams = c.for_scene("kitchen_goal");
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams[0].name, "workcell");
  EXPECT_EQ(cams[0].width, 640);
  EXPECT_EQ(cams[0].height, 480);
  EXPECT_GT(cams[0].fovy, 20);
  EXPECT_GT(cams[0].pos[2], 0.5) << "above the table";
  EXPECT_EQ(cams[1].name, "front");
  EXPECT_LT(cams[1].pos[0], -0.3) << "on the robot's side of the table: the fixtures face it";
}

TEST(RgbdConfig, PerSceneOverridesReplaceOnlyTheirKeys) {
  const auto c = sim::load_cameras_config(temp_file("ok.yaml", R"(rgbd_cameras:
  - {name: top, pos: [0.5, 0, 1.5], look_at: [0, 0, 0], fovy: 50, width: 320, height: 240,
     scenes: {study_caddy: {pos: [0.6, 0.1, 1.2]}}}
  - {name: side, pos: [0, 1.0, 0.8], look_at: [0, 0, 0.1]}
)"));
  ASSERT_EQ(c.cameras.size(), 2u);
  const auto base = c.for_scene("kitchen_goal"), study = c.for_scene("study_caddy");
  EXPECT_EQ(base[0].pos, (Vec3{0.5, 0, 1.5}));
  EXPECT_EQ(study[0].pos, (Vec3{0.6, 0.1, 1.2}));
  EXPECT_EQ(study[0].look_at, (Vec3{0, 0, 0}));
  EXPECT_EQ(study[0].width, 320);
  EXPECT_EQ(study[0].fovy, 50);
  EXPECT_EQ(base[1].name, "side");
  EXPECT_EQ(base[1].width, 640) << "defaults";
  EXPECT_EQ(base[1].fovy, 45);
}

TEST(RgbdConfig, EveryMistakeIsNamedWithItsFileAndKey) {
  const std::pair<std::string, std::string> cases[] = {
      {"rgbd_cameras:\n  - {name: a, look_at: [0, 0, 0]}\n", "pos"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0, 1]}\n", "look_at"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0], look_at: [0, 0, 0]}\n", "expected a list of 3 numbers"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0, 1], look_at: [0, 0, 0], fovy: 0}\n", "fovy"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0, 1], look_at: [0, 0, 0], width: 0}\n", "width"},
      {"rgbd_cameras:\n  - {name: a, pos: [0, 0, 1], look_at: [0, 0, 0]}\n", "straight above or below"},
      {"rgbd_cameras:\n  - {name: agentview, pos: [1, 0, 1], look_at: [0, 0, 0]}\n", "already a camera"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0, 1], look_at: [0, 0, 0]}\n  - {name: a, pos: [1, 0, 1], "
       "look_at: [0, 0, 0]}\n",
       "defined twice"},
      {"rgbd_cameras:\n  - {name: a, pos: [1, 0, 1], look_at: [0, 0, 0], scenes: {s: {fovy: 200}}}\n",
       "scenes.s.fovy"},
      {"cameras: []\n", "rgbd_cameras"},
      {"rgbd_cameras: [\n", "cameras_bad"},
  };
  int i = 0;
  for (const auto& [yaml, expect] : cases) {
    const auto file = temp_file("cameras_bad" + std::to_string(i++) + ".yaml", yaml);
    try {
      sim::load_cameras_config(file);
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.filename().string()), std::string::npos) << e.what();
    }
  }
}

// ---- rendered frames -------------------------------------------------------------------------------------

class RgbdRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    gl = new sim::GlContext();
    std::printf("renderer: %s\n", sim::check_rendering(*gl, 64, 64).c_str());
    gl->make_current();
  }
  static void TearDownTestSuite() {
    delete gl;
    gl = nullptr;
  }
  static sim::GlContext* gl;
};
sim::GlContext* RgbdRender::gl = nullptr;

std::uint16_t depth_at(const std::vector<std::uint16_t>& d, int width, double u, double v) {
  return d[static_cast<std::size_t>(std::lround(v)) * width + std::lround(u)];
}

/// The `xyaxes` of a MuJoCo camera at `pos` looking at `target`, world z up in the image.
std::string xyaxes(const Vec3& pos, const Vec3& target) {
  Vec3 f{target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]};
  Vec3 x{f[1], -f[0], 0};
  const double nx = std::hypot(x[0], x[1]), nf = std::hypot(f[0], f[1], f[2]);
  for (double& v : x) v /= nx;
  for (double& v : f) v /= nf;
  const Vec3 y{x[1] * f[2] - x[2] * f[1], x[2] * f[0] - x[0] * f[2], x[0] * f[1] - x[1] * f[0]};
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.12g %.12g %.12g %.12g %.12g %.12g", x[0], x[1], x[2], y[0], y[1], y[2]);
  return buf;
}

// A grey plane at z = 0 and a red 10 x 6 x 4 cm box standing on it off the optical axis, seen from above
// at an angle: the box's top face and the plane come out where and how deep the intrinsics and pose say,
// to the pixel and to the millimetre.
TEST_F(RgbdRender, AConstructedSceneComesOutWhereAndAsDeepAsTheIntrinsicsAndPoseSay) {
  const Vec3 cam{0.9, -0.3, 1.1}, target{0.05, 0.05, 0};
  const Vec3 box_centre{0.12, 0.1, 0.02}, box_half{0.05, 0.03, 0.02};
  char xml[2048];
  std::snprintf(
      xml, sizeof xml,
      "<mujoco><visual><global offwidth=\"640\" offheight=\"480\"/><quality offsamples=\"0\"/></visual>"
      "<worldbody><light pos=\"0 0 3\" dir=\"0 0 -1\" directional=\"true\"/>"
      "<geom type=\"plane\" size=\"2 2 0.1\" rgba=\"0.5 0.5 0.5 1\"/>"
      "<geom type=\"box\" size=\"%g %g %g\" pos=\"%g %g %g\" rgba=\"0.9 0.1 0.1 1\"/>"
      "<camera name=\"rgbd\" pos=\"%g %g %g\" xyaxes=\"%s\" fovy=\"45\"/></worldbody></mujoco>",
      box_half[0], box_half[1], box_half[2], box_centre[0], box_centre[1], box_centre[2], cam[0], cam[1],
      cam[2], xyaxes(cam, target).c_str());
  sim::ModelPtr m = sim::compile_model(xml, "rgbd test scene");
  sim::DataPtr d = sim::make_data(m.get());
  mj_forward(m.get(), d.get());
  sim::CameraRig rig(m.get(), d.get(), {"rgbd"}, 640, 480);
  sim::Image img;
  std::vector<std::uint16_t> depth;
  rig.render(0, img, depth);
  save(img, depth, "constructed");
  ASSERT_EQ(depth.size(), 640u * 480u);
  const auto K = sim::camera_pinhole(m.get(), "rgbd", 640, 480);
  const auto pose = sim::camera_pose(m.get(), d.get(), "rgbd");
  EXPECT_NEAR(pose.position[0], cam[0], 1e-9);
  const auto [zn, zf] = sim::model_clip_planes(m.get());
  std::printf("clip planes %.4f .. %.1f m\n", zn, zf);

  // The look-at point: the image centre, at its distance.
  const double dist = std::hypot(target[0] - cam[0], target[1] - cam[1], target[2] - cam[2]);
  const auto c = sim::project(K, pose, target);
  EXPECT_NEAR(c.u, 319.5, 1e-9);
  EXPECT_NEAR(c.z, dist, 1e-9);

  // The plane: every pixel off the box back-projects onto z = 0 (to the millimetre).
  int plane_px = 0;
  double worst = 0;
  for (int v = 0; v < 480; v += 7)
    for (int u = 0; u < 640; u += 7) {
      const auto z = depth[v * 640 + u];
      if (!z) continue;
      const auto w = sim::back_project(K, pose, u, v, z / 1000.0);
      if (std::abs(w[0] - box_centre[0]) < box_half[0] + 0.02 &&
          std::abs(w[1] - box_centre[1]) < box_half[1] + 0.02)
        continue;
      ++plane_px;
      worst = std::max(worst, std::abs(w[2]));
    }
  std::printf("plane: %d pixels, worst |z| %.4f m\n", plane_px, worst);
  EXPECT_GT(plane_px, 5000);
  EXPECT_LT(worst, 0.002 + 0.0005 * dist) << "the plane is not at z = 0 in the published geometry";

  // The box's top face centre: its depth along the optical axis, and red.
  const Vec3 top{box_centre[0], box_centre[1], box_centre[2] + box_half[2]};
  const auto p = sim::project(K, pose, top);
  const double got = depth_at(depth, 640, p.u, p.v) / 1000.0;
  std::printf("box top at (%.2f, %.2f): depth %.4f m, expected %.4f m\n", p.u, p.v, got, p.z);
  EXPECT_NEAR(got, p.z, 0.002);
  const auto* px = img.pixel(static_cast<int>(std::lround(p.v)), static_cast<int>(std::lround(p.u)));
  EXPECT_GT(px[0], 2 * px[1]) << "not red: " << int(px[0]) << "," << int(px[1]) << "," << int(px[2]);
  EXPECT_GT(px[0], 2 * px[2]);

  // The box's top face edges, to the pixel: along the image row through the top face's centre, red
  // starts and ends where the face's outline crosses that row.
  const int row = static_cast<int>(std::lround(p.v));
  int first = -1, last = -1;
  for (int u = 0; u < 640; ++u) {
    const auto* q = img.pixel(row, u);
    if (q[0] > 2 * q[1] && q[0] > 2 * q[2] && q[0] > 60) {
      if (first < 0) first = u;
      last = u;
    }
  }
  ASSERT_GE(first, 0);
  // Where the top face's outline crosses the row: sample the outline finely and keep the crossings.
  double lo = 1e9, hi = -1e9;
  const Vec3 corners[4] = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  for (int e = 0; e < 4; ++e)
    for (int k = 0; k <= 2000; ++k) {
      const double t = k / 2000.0;
      Vec3 w;
      for (int i = 0; i < 2; ++i)
        w[i] = box_centre[i] + box_half[i] * (corners[e][i] * (1 - t) + corners[(e + 1) % 4][i] * t);
      w[2] = top[2];
      const auto q = sim::project(K, pose, w);
      if (std::abs(q.v - row) < 0.02) {
        lo = std::min(lo, q.u);
        hi = std::max(hi, q.u);
      }
    }
  // The side faces are red too and may show beyond the top face's outline on one side: compare the left
  // edge only where the top face's outline is the silhouette (the camera sees the box's -y, +x sides).
  std::printf("red from column %d to %d; top face outline %.2f .. %.2f\n", first, last, lo, hi);
  EXPECT_NEAR(first, lo, 1.0) << "the image is shifted or mirrored against the published intrinsics";
  EXPECT_LE(hi, last + 1.0);
}

const TaskDef& bowl_on_plate() {
  static const auto suites = load_suites(paths::config_dir());
  return find_task(suites, "goal", 8);
}

/// Which of `palette` (linear RGB 0..1) `c` is, allowing for shading (a factor 0.55 .. 1.5): the index of
/// the smallest residual.
std::size_t nearest_colour(const std::uint8_t* c, const std::vector<std::array<double, 4>>& palette) {
  std::size_t best = 0;
  double best_r = 1e9;
  for (std::size_t i = 0; i < palette.size(); ++i) {
    const auto& p = palette[i];
    const double pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    const double cp = (c[0] * p[0] + c[1] * p[1] + c[2] * p[2]) / 255.0;
    const double k = std::clamp(cp / pp, 0.55, 1.5);
    double r = 0;
    for (int j = 0; j < 3; ++j) r += std::pow(c[j] / 255.0 - k * p[j], 2);
    if (r < best_r) best_r = r, best = i;
  }
  return best;
}

// The goal kitchen through the configured workcell camera: 640 x 480, the table top back-projects onto
// z = 0, and each entity's top face lies at its projected pixel at the projected depth, in its colour.
TEST_F(RgbdRender, TheWorkcellCameraSeesTheKitchenWhereItsPublishedGeometrySays) {
  sim::SceneSpec spec = sim::load_task_scene(bowl_on_plate(), 1);
  const auto config = sim::load_cameras_config(paths::config_dir() / "cameras.yaml");
  spec.cameras = config.for_scene(spec.name);
  sim::Workcell cell(spec);
  cell.reset(4, bowl_on_plate().goal);
  const auto state_before = cell.digest();  // of the live data the renderer reads
  sim::CameraRig rig(cell, {"workcell"}, 640, 480);
  sim::Image img;
  std::vector<std::uint16_t> depth;
  const auto t0 = std::chrono::steady_clock::now();
  constexpr int kFrames = 5;
  for (int i = 0; i < kFrames; ++i) rig.render(0, img, depth);
  std::printf(
      "640x480 RGB-D frame: %.1f ms each (render + read + linearise), %d frames\n",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / kFrames,
      kFrames);
  save(img, depth, "workcell_kitchen_goal");
  EXPECT_EQ(cell.digest(), state_before) << "rendering changed the physics";
  ASSERT_EQ(img.width, 640);
  ASSERT_EQ(img.height, 480);
  const auto K = sim::camera_pinhole(cell.model(), "workcell", 640, 480);
  const auto pose = sim::camera_pose(cell.model(), cell.data(), "workcell");
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(pose.position[i], spec.cameras[0].pos[i], 1e-9);
  std::printf(
      "workcell camera: fx=fy=%.3f cx=%.1f cy=%.1f; position %.3f %.3f %.3f, orientation (w x y z) %.4f %.4f "
      "%.4f %.4f\n",
      K.fx, K.cx, K.cy, pose.position[0], pose.position[1], pose.position[2], pose.wxyz[0], pose.wxyz[1],
      pose.wxyz[2], pose.wxyz[3]);
  // The configured look-at point is the image centre.
  const auto centre = sim::project(K, pose, spec.cameras[0].look_at);
  EXPECT_NEAR(centre.u, K.cx, 1e-6);
  EXPECT_NEAR(centre.v, K.cy, 1e-6);

  // Table top: pixels that back-project into the table's footprint near its surface lie on z = 0.
  std::vector<double> table_z;
  for (int v = 0; v < 480; v += 4)
    for (int u = 0; u < 640; u += 4) {
      const auto z = depth[v * 640 + u];
      if (!z) continue;
      const auto w = sim::back_project(K, pose, u, v, z / 1000.0);
      if (std::abs(w[0]) < 0.48 && std::abs(w[1]) < 0.58 && std::abs(w[2]) < 0.01) table_z.push_back(w[2]);
    }
  ASSERT_GT(table_z.size(), 3000u) << "the table is not in view";
  std::sort(table_z.begin(), table_z.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  const double p95 = std::abs(table_z[table_z.size() * 95 / 100]);
  std::printf("table top: %zu pixels, |z| p50 %.4f m, p95 %.4f m\n", table_z.size(),
              std::abs(table_z[table_z.size() / 2]), p95);
  EXPECT_LT(std::abs(table_z[table_z.size() / 2]), 0.001);
  EXPECT_LT(p95, 0.003);

  // Entities with a solid top face (not the bowl's hollow, the rack's bars): the top face's centre is
  // where the pose and intrinsics put it, as deep as they say, in the entity's colour.
  std::vector<std::array<double, 4>> palette{spec.table_rgba};
  std::vector<std::string> names{"table"};
  for (const auto& e : spec.entities) palette.push_back(e.rgba), names.push_back(e.name);
  const auto obs = cell.observe();
  int checked = 0;
  for (const std::string name : {"plate", "cream_cheese", "cabinet", "wine_bottle"}) {
    const auto* e = obs.entity(name);
    ASSERT_NE(e, nullptr) << name;
    // The plate's centre is its disc's top (1 cm up, configs/assets/plate.yaml), below the rim's top.
    const double height = name == "plate" ? 0.010 : 2 * e->half_extents[2];
    const Vec3 top{e->p[0], e->p[1], e->p[2] + height};
    const auto p = sim::project(K, pose, top);
    ASSERT_TRUE(p.u >= 0 && p.u <= 639 && p.v >= 0 && p.v <= 479) << name << " is out of view";
    const double got = depth_at(depth, 640, p.u, p.v) / 1000.0;
    const auto* px = img.pixel(static_cast<int>(std::lround(p.v)), static_cast<int>(std::lround(p.u)));
    const auto is = names[nearest_colour(px, palette)];
    std::printf(
        "%-13s top (%.3f, %.3f, %.3f) at pixel (%.1f, %.1f): depth %.4f m, expected %.4f m; colour %d,%d,%d "
        "looks like %s\n",
        name.c_str(), top[0], top[1], top[2], p.u, p.v, got, p.z, px[0], px[1], px[2], is.c_str());
    EXPECT_NEAR(got, p.z, 0.004) << name;
    EXPECT_EQ(is, name) << name << "'s colour is not at its projected pixel";
    ++checked;
  }
  EXPECT_EQ(checked, 4);
}

}  // namespace
}  // namespace dh
