// Cameras of the workcell, rendered headless (EGL surfaceless): both cameras of the goal kitchen give
// sensible images, the wrist camera follows the arm, the agentview sees the bowl, and neither the
// cameras in the model nor rendering changes the physics. Each camera's image is saved as a PNG (PPM
// without libpng) in $DH_CAMERA_PNG_DIR (default: <temp>/dh_test_cameras) for a person to look at.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#if DH_HAVE_PNG
#include <png.h>
#endif

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

constexpr int kSize = sim::kDefaultCameraSize;
constexpr std::uint64_t kSeed = 4;

const TaskDef& bowl_on_plate() {
  static const auto suites = load_suites(paths::config_dir());
  return find_task(suites, "goal", 8);
}

std::filesystem::path png_dir() {
  const char* v = std::getenv("DH_CAMERA_PNG_DIR");
  const std::filesystem::path dir = v && *v ? v : std::filesystem::temp_directory_path() / "dh_test_cameras";
  std::filesystem::create_directories(dir);
  return dir;
}

/// Writes an RGB8 image as `<stem>.png` (libpng) or `<stem>.ppm`; returns the file, empty on failure.
std::filesystem::path write_image(const sim::Image& img, const std::string& stem) {
#if DH_HAVE_PNG
  const auto file = png_dir() / (stem + ".png");
  FILE* f = std::fopen(file.c_str(), "wb");
  if (!f) return {};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  bool ok = png && info && !setjmp(png_jmpbuf(png));
  if (ok) {
    png_init_io(png, f);
    png_set_IHDR(png, info, img.width, img.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int r = 0; r < img.height; ++r) png_write_row(png, const_cast<png_bytep>(img.pixel(r, 0)));
    png_write_end(png, nullptr);
  }
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
  return ok ? file : std::filesystem::path();
#else
  const auto file = png_dir() / (stem + ".ppm");
  std::ofstream out(file, std::ios::binary);
  out << "P6\n" << img.width << " " << img.height << "\n255\n";
  out.write(reinterpret_cast<const char*>(img.rgb.data()), static_cast<std::streamsize>(img.rgb.size()));
  return out ? file : std::filesystem::path();
#endif
}

struct Stats {
  double mean = 0, stddev = 0;
};
Stats luminance(const sim::Image& img) {
  double s = 0, s2 = 0;
  const std::size_t n = img.rgb.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    const double y = (img.rgb[3 * i] + img.rgb[3 * i + 1] + img.rgb[3 * i + 2]) / 3.0;
    s += y;
    s2 += y * y;
  }
  const double mean = s / n;
  return {mean, std::sqrt(std::max(0.0, s2 / n - mean * mean))};
}

/// Mean absolute difference per channel over the image, 0..255.
double mean_abs_diff(const sim::Image& a, const sim::Image& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) s += std::abs(int(a.rgb[i]) - int(b.rgb[i]));
  return s / a.rgb.size();
}

/// Mean absolute difference over the (2r+1)^2 window around (row, col).
double window_diff(const sim::Image& a, const sim::Image& b, int row, int col, int r) {
  double s = 0;
  int n = 0;
  for (int y = std::max(0, row - r); y <= std::min(a.height - 1, row + r); ++y)
    for (int x = std::max(0, col - r); x <= std::min(a.width - 1, col + r); ++x, ++n)
      for (int c = 0; c < 3; ++c) s += std::abs(int(a.pixel(y, x)[c]) - int(b.pixel(y, x)[c]));
  return n ? s / (3 * n) : 0;
}

/// Where a world point appears in a camera's image (row, col), from the camera's pose and fovy.
std::array<double, 2> project(const sim::Workcell& cell, const std::string& camera,
                              const std::array<double, 3>& p, int width, int height) {
  const mjModel* m = cell.model();
  const mjData* d = cell.data();
  const int id = mj_name2id(m, mjOBJ_CAMERA, camera.c_str());
  const double* c = d->cam_xpos + 3 * id;
  const double* R = d->cam_xmat + 9 * id;  // columns: the camera's x, y, z axes in the world
  const double v[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
  double pc[3];
  for (int k = 0; k < 3; ++k) pc[k] = R[k] * v[0] + R[3 + k] * v[1] + R[6 + k] * v[2];
  const double f = (height / 2.0) / std::tan(m->cam_fovy[id] * M_PI / 360.0);
  return {height / 2.0 - f * pc[1] / -pc[2], width / 2.0 + f * pc[0] / -pc[2]};
}

std::array<double, 3> entity_position(const sim::Workcell& cell, const std::string& name) {
  for (const auto& e : cell.observe().entities)
    if (e.name == name) return e.p;
  ADD_FAILURE() << "no entity " << name;
  return {};
}

class Cameras : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    gl = new sim::GlContext();
    std::printf("renderer: %s\n", sim::check_rendering(*gl, kSize, kSize).c_str());
    gl->make_current();
  }
  static void TearDownTestSuite() {
    delete gl;
    gl = nullptr;
  }
  static sim::GlContext* gl;
};
sim::GlContext* Cameras::gl = nullptr;

TEST_F(Cameras, BothCamerasOfTheGoalKitchenGiveSensibleImages) {
  sim::Workcell cell(sim::load_task_scene(bowl_on_plate(), 1));
  cell.reset(kSeed, bowl_on_plate().goal);
  const auto made = std::chrono::steady_clock::now();
  sim::CameraRig rig(cell, sim::workcell_cameras(), kSize, kSize);
  std::printf("camera rig (mjr_makeContext, mjv_makeScene) made in %.1f ms\n",
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - made).count());
  ASSERT_EQ(rig.cameras().size(), 2u);
  for (std::size_t i = 0; i < rig.cameras().size(); ++i) {
    const auto& name = rig.cameras()[i];
    sim::Image img;
    rig.render(i, img);  // the first frame compiles llvmpipe's shaders
    const auto t0 = std::chrono::steady_clock::now();
    constexpr int kFrames = 20;
    for (int k = 0; k < kFrames; ++k) rig.render(i, img);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / kFrames;
    ASSERT_EQ(img.width, kSize);
    ASSERT_EQ(img.height, kSize);
    ASSERT_EQ(img.rgb.size(), std::size_t(kSize) * kSize * 3);
    const Stats s = luminance(img);
    EXPECT_GT(s.mean, 30) << name << ": too dark";
    EXPECT_GT(s.stddev, 15) << name << ": nearly uniform";
    const auto file = write_image(img, "goal_task8_seed4_" + name);
    EXPECT_FALSE(file.empty()) << "cannot save the " << name << " image in " << png_dir();
    std::printf("%s: %dx%d, %.1f ms per image, luminance mean %.1f sd %.1f -> %s\n", name.c_str(), img.width,
                img.height, ms, s.mean, s.stddev, file.c_str());
  }
}

TEST_F(Cameras, TheWristImageFollowsTheArm) {
  sim::Workcell cell(sim::load_task_scene(bowl_on_plate(), 1));
  cell.reset(kSeed, bowl_on_plate().goal);
  sim::CameraRig rig(cell, {sim::kWristCamera, sim::kAgentviewCamera}, kSize, kSize);
  const sim::Image wrist0 = rig.render(0), agent0 = rig.render(1);
  // 10 steps: 25 cm towards +y and a quarter turn of the wrist.
  for (int s = 0; s < 10; ++s) cell.step({0, 0.5, 0, 0, 0, 0.3, -1});
  const sim::Image wrist1 = rig.render(0), agent1 = rig.render(1);
  write_image(wrist1, "goal_task8_seed4_wrist_moved");
  const double wrist_change = mean_abs_diff(wrist0, wrist1), agent_change = mean_abs_diff(agent0, agent1);
  std::printf("arm moved: wrist image changed %.1f/255, agentview %.1f/255\n", wrist_change, agent_change);
  EXPECT_GT(wrist_change, 10);
  EXPECT_GT(agent_change, 0.5) << "the agentview should see the arm move";
  EXPECT_GT(wrist_change, 3 * agent_change) << "the wrist view should change far more than the fixed view";
}

TEST_F(Cameras, TheAgentviewSeesTheBowlWhereItIs) {
  sim::SceneSpec scene = sim::load_task_scene(bowl_on_plate(), 1);
  sim::Workcell here(scene);
  here.reset(kSeed, bowl_on_plate().goal);
  // The same scene with the bowl across the table, on the cabinet's side.
  for (auto& e : scene.entities)
    if (e.name == "bowl") e.nominal_xy = {0.3, -0.5};
  sim::Workcell away(scene);
  away.reset(kSeed, bowl_on_plate().goal);
  sim::CameraRig rig_here(here, {sim::kAgentviewCamera}, kSize, kSize);
  sim::CameraRig rig_away(away, {sim::kAgentviewCamera}, kSize, kSize);
  const sim::Image a = rig_here.render(0), b = rig_away.render(0);
  write_image(b, "goal_task8_seed4_agentview_bowl_moved");
  const auto bowl = entity_position(here, "bowl");
  const auto [row, col] =
      project(here, sim::kAgentviewCamera, {bowl[0], bowl[1], bowl[2] + 0.02}, kSize, kSize);
  ASSERT_GT(row, 0);
  ASSERT_LT(row, kSize);
  ASSERT_GT(col, 0);
  ASSERT_LT(col, kSize);
  const double at_bowl = window_diff(a, b, int(row), int(col), 3);
  const double elsewhere = mean_abs_diff(a, b);
  std::printf("bowl at pixel (%.0f, %.0f): difference there %.1f/255, over the image %.1f/255\n", row, col,
              at_bowl, elsewhere);
  EXPECT_GT(at_bowl, 40) << "the bowl is not where the camera should see it";
  EXPECT_GT(at_bowl, 10 * elsewhere);
  // The bowl is dark (rgba 0.1): the pixel at its projection is dark in `a`.
  const std::uint8_t* px = a.pixel(int(row), int(col));
  EXPECT_LT((px[0] + px[1] + px[2]) / 3, 60);
}

TEST_F(Cameras, EveryBenchmarkSceneHasBothCameras) {
  static const auto suites = load_suites(paths::config_dir());
  std::map<std::filesystem::path, const TaskDef*> scenes;  // one task per scene file, unperturbed
  for (const char* suite : {"goal", "long"})
    for (const auto& [id, task] : suites.at(suite).tasks) scenes.emplace(task.scene_file, &task);
  EXPECT_GE(scenes.size(), 9u);
  for (const auto& [file, task] : scenes) {
    sim::Workcell cell(sim::load_task_scene(*task, 1));
    cell.reset(1, task->goal);
    sim::CameraRig rig(cell, sim::workcell_cameras(), kSize, kSize);
    for (std::size_t i = 0; i < rig.cameras().size(); ++i) {
      const sim::Image img = rig.render(i);
      const Stats s = luminance(img);
      EXPECT_GT(s.mean, 30) << file << " " << rig.cameras()[i];
      EXPECT_GT(s.stddev, 15) << file << " " << rig.cameras()[i];
      write_image(img, file.stem().string() + "_seed1_" + rig.cameras()[i]);
    }
  }
}

// Cameras are MJCF elements without mass or contacts, and rendering only reads the state.
TEST_F(Cameras, NeitherTheCamerasNorRenderingChangeThePhysics) {
  const sim::SceneSpec scene = sim::load_task_scene(bowl_on_plate(), 1);
  const std::string xml = sim::scene_mjcf(scene, sim::sample_placements(scene, kSeed));
  ASSERT_NE(xml.find("<camera name=\"agentview\""), std::string::npos);
  ASSERT_NE(xml.find("<camera name=\"wrist\""), std::string::npos);
  const std::string bare = std::regex_replace(xml, std::regex("<camera [^>]*/>\n"), "");
  ASSERT_EQ(bare.find("<camera"), std::string::npos);
  auto with = sim::compile_model(xml, "with cameras"), without = sim::compile_model(bare, "without cameras");
  EXPECT_EQ(with->ncam, 2);
  EXPECT_EQ(without->ncam, 0);
  ASSERT_EQ(with->nq, without->nq);
  ASSERT_EQ(with->nu, without->nu);
  auto d1 = sim::make_data(with.get()), d2 = sim::make_data(without.get());
  sim::CameraRig rig(with.get(), d1.get(), sim::workcell_cameras(), kSize, kSize);
  for (int s = 0; s < 500; ++s) {
    for (int u = 0; u < with->nu; ++u) d1->ctrl[u] = d2->ctrl[u] = 5 * std::sin(0.01 * s + u);
    mj_step(with.get(), d1.get());
    mj_step(without.get(), d2.get());
    if (s % 25 == 0) rig.render(s / 25 % 2);
  }
  EXPECT_EQ(0, std::memcmp(d1->qpos, d2->qpos, sizeof(mjtNum) * with->nq));
  EXPECT_EQ(0, std::memcmp(d1->qvel, d2->qvel, sizeof(mjtNum) * with->nv));
}

TEST_F(Cameras, AskingForTheImpossibleIsAClearError) {
  sim::Workcell cell(sim::load_task_scene(bowl_on_plate(), 1));
  try {
    sim::CameraRig rig(cell, {"birdseye"}, kSize, kSize);
    ADD_FAILURE() << "no error for an unknown camera";
  } catch (const sim::RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("no camera 'birdseye' (it has: agentview, wrist)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(sim::CameraRig(cell, {sim::kWristCamera}, 2000, 2000), sim::RenderError);
}

}  // namespace
}  // namespace dh
