// grow_by_depth: a seed on an object's lit top grows over the depth image into the object's walls, never
// onto the table or into an object standing apart.
#include <gtest/gtest.h>

#include "dh/perception/grow.hpp"
#include "synthetic_scene.hpp"

namespace dh::perception {
namespace {

/// A grey pot, and a wider box of the same grey standing right behind it: in the image the box's front
/// face borders the pot's silhouette, with a depth step of several centimetres between them.
synth::Scene pot_and_box_behind() {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.cylinders = {synth::Cylinder{Eigen::Vector3d(0.0, 0.0, 0.0), 0.038, 0.16, {150, 150, 155}}};
  s.boxes = {
      synth::Box{Eigen::Vector3d(0.0, 0.1, 0.08), 0, Eigen::Vector3d(0.16, 0.06, 0.16), {150, 150, 155}}};
  return s;
}
constexpr int kBox = 1, kPot = 2;  // boxes first, then cylinders

/// Pot pixels 4-adjacent to box pixels: where only the depth step can stop the growth.
int borders(const synth::Rendered& r) {
  int n = 0;
  for (int v = 1; v < r.ids.rows; ++v)
    for (int u = 1; u < r.ids.cols; ++u)
      n += (r.ids(v, u) == kPot && (r.ids(v - 1, u) == kBox || r.ids(v, u - 1) == kBox)) ||
           (r.ids(v, u) == kBox && (r.ids(v - 1, u) == kPot || r.ids(v, u - 1) == kPot));
  return n;
}

TEST(GrowByDepth, ALitTopGrowsIntoItsWallsAndStopsAtTheTableAndAtADepthStep) {
  const auto r = synth::render(pot_and_box_behind(), synth::Noise{0, 0, 1.0, 0.01, 3});
  ASSERT_GT(borders(r), 20) << "the box must border the pot in the image";
  const cv::Mat1b seed = synth::id_mask_above(r, kPot, 0.158);
  ASSERT_GT(cv::countNonZero(seed), 200);
  GrowParams g;
  g.max_radius_m = 0.2;  // reaches the box: only the depth step keeps it out
  g.max_height_m = 0.17;
  const cv::Mat1b grown = grow_by_depth(r.frame, seed, g);
  const cv::Mat1b truth = synth::id_mask(r, kPot);
  ASSERT_GT(cv::countNonZero(truth), 3 * cv::countNonZero(seed)) << "the walls are most of the pot";
  // Pixels of the wall's last 8 mm above the table do not join, nor do those that lost their depth.
  EXPECT_GT(synth::iou(grown, truth), 0.9);
  EXPECT_EQ(cv::countNonZero(grown & synth::id_mask(r, 0)), 0) << "no table pixel";
  EXPECT_EQ(cv::countNonZero(grown & synth::id_mask(r, kBox)), 0) << "no pixel of the box behind it";
  g.max_step_m = 1.0;
  EXPECT_GT(cv::countNonZero(grow_by_depth(r.frame, seed, g) & synth::id_mask(r, kBox)), 1000)
      << "without the depth step the box joins";
}

TEST(GrowByDepth, TheRadiusBoundsTheGrowth) {
  const auto r = synth::render(pot_and_box_behind());
  GrowParams g;
  g.max_radius_m = 0.02;  // inside the pot's 3.8 cm radius
  const cv::Mat1b grown = grow_by_depth(r.frame, synth::id_mask_above(r, kPot, 0.158), g);
  const cv::Mat1b truth = synth::id_mask(r, kPot);
  EXPECT_LT(cv::countNonZero(grown), cv::countNonZero(truth) * 3 / 4);
  EXPECT_EQ(cv::countNonZero(grown & ~truth), 0);
}

TEST(GrowByDepth, ASeedAboveTheObjectsHeightOrWithoutDepthGivesNothingAndABadSeedIsRefused) {
  auto r = synth::render(pot_and_box_behind());
  const cv::Mat1b seed = synth::id_mask_above(r, kPot, 0.158);
  GrowParams low;
  low.max_height_m = 0.1;  // the pot's top is at 0.16 m: taken for something above the object
  EXPECT_EQ(cv::countNonZero(grow_by_depth(r.frame, seed, low)), 0);
  r.frame.depth.setTo(0);
  EXPECT_EQ(cv::countNonZero(grow_by_depth(r.frame, seed, {})), 0);
  try {
    grow_by_depth(r.frame, cv::Mat1b(10, 10, 255), {});
    FAIL() << "a 10x10 seed for a 640x480 frame";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("10x10"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dh::perception
