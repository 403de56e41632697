// Back-projection, the cloud stages and estimate_entity on constructed frames with analytic truth.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "dh/perception/estimate.hpp"
#include "synthetic_scene.hpp"

namespace dh::perception {
namespace {

using synth::Box;
using synth::Rendered;
using synth::Scene;

Eigen::Vector3d mean_of(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (const auto& p : pts) m += p;
  return m / static_cast<double>(pts.size());
}

/// The exact surface points of the pixels in `mask` (unquantised depths), row-major like back_project.
std::vector<Eigen::Vector3d> exact_points(const Scene& s, const Rendered& r, const cv::Mat1b& mask) {
  std::vector<Eigen::Vector3d> out;
  for (int v = 0; v < mask.rows; ++v)
    for (int u = 0; u < mask.cols; ++u)
      if (mask(v, u)) {
        Eigen::Vector3d o, d;
        synth::pixel_ray(s, u, v, o, d);
        out.push_back(o + r.exact_depth_m(v, u) * d);
      }
  return out;
}

CloudParams no_erosion() {
  CloudParams p;
  p.mask_erode_px = 0;
  return p;
}

TEST(BackProjection, FrontoParallelPlaneIsExact) {
  // Depth 1000 mm everywhere, camera at the origin: each point is the pixel's ray at z = 1 m, exactly.
  RgbdFrame f;
  f.K = {600.0, 580.0, 159.5, 119.5, 320, 240};
  f.depth = cv::Mat(240, 320, CV_16UC1, cv::Scalar(1000));
  const cv::Mat1b all(240, 320, static_cast<unsigned char>(255));
  const BackProjection bp = back_project(f, all, no_erosion());
  ASSERT_EQ(bp.points.size(), 320u * 240u);
  EXPECT_EQ(bp.mask_px, bp.valid_px);
  for (std::size_t i = 0; i < bp.points.size(); i += 997) {
    const int u = static_cast<int>(i % 320), v = static_cast<int>(i / 320);
    EXPECT_NEAR(bp.points[i].x(), (u - 159.5) / 600.0, 1e-12);
    EXPECT_NEAR(bp.points[i].y(), (v - 119.5) / 580.0, 1e-12);
    EXPECT_NEAR(bp.points[i].z(), 1.0, 1e-12);
  }
  // The centroid of a symmetric pixel grid about the principal point is on the optical axis.
  EXPECT_LT(mean_of(bp.points).head<2>().norm(), 1e-9);
}

TEST(BackProjection, TiltedTablePlaneFromAPosedCameraLiesOnThePlane) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.table_z = 0.02;
  const Rendered r = synth::render(s);
  const cv::Mat1b table = synth::id_mask(r, 0);
  const BackProjection bp = back_project(r.frame, table, no_erosion());
  ASSERT_GT(bp.points.size(), 100000u);
  // Depth is quantised to 1 mm: a point moves at most 0.5 mm * |ray| (ray z = 1, |ray| < 1.2 here) off
  // the exact point, so at most that far from the plane.
  for (const auto& p : bp.points) ASSERT_NEAR(p.z(), 0.02, 0.0006);
  const Eigen::Vector3d exact = mean_of(exact_points(s, r, table));
  EXPECT_LT((mean_of(bp.points) - exact).norm(), 0.001);
}

TEST(BackProjection, BoxAtAKnownPoseLiesOnTheBoxSurface) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Box box{Eigen::Vector3d(0.05, 0.03, 0.04), 0.5, Eigen::Vector3d(0.12, 0.07, 0.08), {200, 40, 40}};
  s.boxes = {box};
  const Rendered r = synth::render(s);
  const cv::Mat1b mask = synth::id_mask(r, 1);
  const BackProjection bp = back_project(r.frame, mask, no_erosion());
  ASSERT_GT(bp.points.size(), 3000u);
  const Eigen::Matrix3d R = synth::yaw_rotation(box.yaw);
  for (const auto& p : bp.points) {
    // Distance to the box surface: for a point near it, max over the axes of |q_i| - h_i.
    const Eigen::Vector3d q = R.transpose() * (p - box.centre);
    const double sd = (q.cwiseAbs() - 0.5 * box.size).maxCoeff();
    ASSERT_LT(std::abs(sd), 0.0007) << p.transpose();
  }
  EXPECT_LT((mean_of(bp.points) - mean_of(exact_points(s, r, mask))).norm(), 0.001);
}

TEST(BackProjection, InvalidDepthIsCountedAndSkipped) {
  RgbdFrame f;
  f.K = {500.0, 500.0, 31.5, 23.5, 64, 48};
  f.depth = cv::Mat(48, 64, CV_16UC1, cv::Scalar(800));
  f.depth(cv::Rect(0, 0, 64, 12)).setTo(0);     // no reading
  f.depth(cv::Rect(0, 12, 64, 12)).setTo(5000);  // beyond max_depth_m (3 m)
  const cv::Mat1b all(48, 64, static_cast<unsigned char>(255));
  const BackProjection bp = back_project(f, all, no_erosion());
  EXPECT_EQ(bp.mask_px, 64u * 48u);
  EXPECT_EQ(bp.valid_px, 64u * 24u);
  EXPECT_EQ(bp.points.size(), 64u * 24u);
  EXPECT_THROW(back_project(f, cv::Mat1b(10, 10, static_cast<unsigned char>(255))), std::invalid_argument);
  RgbdFrame bad = f;
  bad.depth = cv::Mat(48, 64, CV_32FC1, cv::Scalar(1.0f));
  EXPECT_THROW(back_project(bad, all), std::invalid_argument);
}

TEST(BackProjection, ErosionDropsTheMaskBorder) {
  RgbdFrame f;
  f.K = {500.0, 500.0, 31.5, 23.5, 64, 48};
  f.depth = cv::Mat(48, 64, CV_16UC1, cv::Scalar(800));
  cv::Mat1b m = cv::Mat1b::zeros(48, 64);
  m(cv::Rect(10, 10, 20, 10)).setTo(255);
  CloudParams p;
  p.mask_erode_px = 1;
  EXPECT_EQ(back_project(f, m, p).mask_px, 18u * 8u);
  p.mask_erode_px = 2;
  EXPECT_EQ(back_project(f, m, p).mask_px, 16u * 6u);
}

/// Points on a regular grid inside a ball.
std::vector<Eigen::Vector3d> blob(const Eigen::Vector3d& c, double radius, double step) {
  std::vector<Eigen::Vector3d> out;
  const int n = static_cast<int>(radius / step);
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) {
        const Eigen::Vector3d d(i * step, j * step, k * step);
        if (d.norm() <= radius) out.push_back(c + d);
      }
  return out;
}

TEST(Clustering, TwoSeparatedBlobsLargestFirst) {
  const auto small = blob({0.3, 0.0, 0.05}, 0.02, 0.004);
  const auto large = blob({0.0, 0.0, 0.05}, 0.035, 0.004);
  std::vector<Eigen::Vector3d> pts = small;  // the small one first in the input
  pts.insert(pts.end(), large.begin(), large.end());
  const auto clusters = euclidean_clusters(pts, 0.012);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0].size(), large.size());
  EXPECT_EQ(clusters[1].size(), small.size());
  EXPECT_LT((mean_of(clusters[0]) - Eigen::Vector3d(0.0, 0.0, 0.05)).norm(), 1e-6);
  EXPECT_LT((mean_of(clusters[1]) - Eigen::Vector3d(0.3, 0.0, 0.05)).norm(), 1e-6);
  // Moved to within the tolerance (5 mm gap) they are one cluster.
  std::vector<Eigen::Vector3d> near = blob({0.06, 0.0, 0.05}, 0.02, 0.004);
  near.insert(near.end(), large.begin(), large.end());
  EXPECT_EQ(euclidean_clusters(near, 0.012).size(), 1u);
}

TEST(Estimate, MaskCoveringTwoObjectsKeepsTheLargerCluster) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Box big{Eigen::Vector3d(-0.06, 0.0, 0.04), 0.0, Eigen::Vector3d(0.08, 0.08, 0.08), {200, 40, 40}};
  const Box small{Eigen::Vector3d(0.12, 0.05, 0.02), 0.0, Eigen::Vector3d(0.04, 0.04, 0.04), {200, 40, 40}};
  s.boxes = {big, small};
  const Rendered r = synth::render(s);
  Mask m{"cube", synth::id_mask(r, 1) | synth::id_mask(r, 2), 1.0};
  const EntityEstimate e = estimate_entity(r.frame, m);
  EXPECT_LT((e.centroid - big.centre).norm(), 0.003);
  EXPECT_GT(e.confidence, 0.5);
  EXPECT_LT(e.confidence, 0.95);  // the small box's points were dropped
  Mask clean{"cube", synth::id_mask(r, 1), 1.0};
  EXPECT_GT(estimate_entity(r.frame, clean).confidence, 0.95);
}

/// The table as a grid of points at z = 0 plus a box's visible faces (top and two sides).
std::vector<Eigen::Vector3d> table_grid(double half, double step, double z) {
  std::vector<Eigen::Vector3d> out;
  for (double x = -half; x <= half + 1e-9; x += step)
    for (double y = -half; y <= half + 1e-9; y += step) out.emplace_back(x, y, z);
  return out;
}

std::vector<Eigen::Vector3d> box_faces(const Eigen::Vector3d& c, const Eigen::Vector3d& size, double step) {
  std::vector<Eigen::Vector3d> out;
  const Eigen::Vector3d h = 0.5 * size;
  for (double x = -h.x(); x <= h.x() + 1e-9; x += step)
    for (double y = -h.y(); y <= h.y() + 1e-9; y += step) out.push_back(c + Eigen::Vector3d(x, y, h.z()));
  for (double x = -h.x(); x <= h.x() + 1e-9; x += step)
    for (double z = -h.z(); z < h.z() - 1e-9; z += step) out.push_back(c + Eigen::Vector3d(x, -h.y(), z));
  for (double y = -h.y() + step; y <= h.y() + 1e-9; y += step)
    for (double z = -h.z(); z < h.z() - 1e-9; z += step) out.push_back(c + Eigen::Vector3d(h.x(), y, z));
  return out;
}

TEST(PlaneRemoval, RemovesTheTableUnderAnObject) {
  auto pts = table_grid(0.15, 0.004, 0.0);
  const auto box = box_faces({0.0, 0.0, 0.05}, {0.1, 0.08, 0.1}, 0.004);
  pts.insert(pts.end(), box.begin(), box.end());
  const PlaneRemoval r = remove_support_plane(pts, CloudParams{});
  ASSERT_TRUE(r.removed);
  EXPECT_GT(r.plane[2], 0.999);
  EXPECT_NEAR(r.plane[3], 0.0, 0.001);
  for (const auto& p : r.kept) EXPECT_GT(p.z(), 0.005);
  // Only the box's points at the table (its side faces' lowest row) go with the table.
  EXPECT_GE(r.kept.size(), box.size() - 2 * 60);
  EXPECT_LE(r.kept.size(), box.size());
}

TEST(PlaneRemoval, KeepsAFlatObjectABoxTopAndATiltedPlane) {
  const CloudParams p;
  // A plate alone: a horizontal plane with nothing on it.
  EXPECT_FALSE(remove_support_plane(table_grid(0.1, 0.004, 0.01), p).removed);
  // A box alone: its top face is a large horizontal plane, but its sides lie below it.
  EXPECT_FALSE(remove_support_plane(box_faces({0.0, 0.0, 0.05}, {0.16, 0.16, 0.06}, 0.004), p).removed);
  // A ramp at 30 degrees under a box: not horizontal, not a support.
  auto ramp = table_grid(0.15, 0.004, 0.0);
  for (auto& q : ramp) q.z() = std::tan(30 * M_PI / 180) * q.x();
  const auto box = box_faces({0.0, 0.0, 0.2}, {0.05, 0.05, 0.05}, 0.004);
  ramp.insert(ramp.end(), box.begin(), box.end());
  const PlaneRemoval r = remove_support_plane(ramp, p);
  EXPECT_FALSE(r.removed);
  EXPECT_EQ(r.kept.size(), ramp.size());
}

TEST(Estimate, BoxAtAKnownPoseCentreSizeAndYaw) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Box box{Eigen::Vector3d(0.05, 0.03, 0.04), 0.5, Eigen::Vector3d(0.12, 0.07, 0.08), {200, 40, 40}};
  s.boxes = {box};
  const Rendered r = synth::render(s);
  const EntityEstimate e = estimate_entity(r.frame, Mask{"box", synth::id_mask(r, 1), 1.0});
  // The camera sees the top and two sides, which span the box: the box centre, not the visible points'
  // mean (over a centimetre nearer the camera), is recovered to within a pixel's footprint (1.2 mm at
  // 0.75 m).
  EXPECT_GT((mean_of(back_project(r.frame, synth::id_mask(r, 1)).points) - box.centre).norm(), 0.01);
  EXPECT_LT((e.centroid - box.centre).norm(), 0.0015) << e.centroid.transpose();
  EXPECT_NEAR(e.size.x(), 0.12, 0.002);
  EXPECT_NEAR(e.size.y(), 0.07, 0.002);
  EXPECT_NEAR(e.size.z(), 0.08, 0.002);
  const double yaw = std::atan2(e.axes(1, 0), e.axes(0, 0));
  EXPECT_NEAR(std::remainder(yaw - box.yaw, M_PI), 0.0, 2.0 * M_PI / 180);
  EXPECT_NEAR(e.axes.determinant(), 1.0, 1e-9);
  EXPECT_GT(e.confidence, 0.95);
  EXPECT_EQ(e.entity, "box");
}

TEST(Estimate, MaskBleedingOntoTheTableRemovesThePlaneAndKeepsTheBox) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Box box{Eigen::Vector3d(0.0, 0.0, 0.05), 0.3, Eigen::Vector3d(0.08, 0.06, 0.10), {40, 40, 200}};
  s.boxes = {box};
  const Rendered r = synth::render(s, synth::Noise{0, 0, 1.0, 0.0, 7});
  cv::Mat1b mask = synth::id_mask(r, 1), bleed;
  cv::dilate(mask, bleed, cv::getStructuringElement(cv::MORPH_ELLIPSE, {61, 61}));
  const EntityEstimate clean = estimate_entity(r.frame, Mask{"box", mask, 1.0});
  const EntityEstimate e = estimate_entity(r.frame, Mask{"box", bleed, 1.0});
  // Depth noise 1 mm: the box's extremes stand out by a few sigma.
  EXPECT_LT((e.centroid - box.centre).norm(), 0.003) << e.centroid.transpose();
  EXPECT_NEAR(e.size.z(), 0.10, 0.004);
  EXPECT_LT(e.confidence, 0.5 * clean.confidence);  // most of the bled mask was table
  EXPECT_LT((clean.centroid - box.centre).norm(), 0.003) << clean.centroid.transpose();
}

TEST(Estimate, DepthlessOrEmptyMasksGiveConfidenceZero) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.boxes = {Box{Eigen::Vector3d(0.0, 0.0, 0.04), 0.0, Eigen::Vector3d(0.08, 0.08, 0.08), {200, 40, 40}}};
  Rendered r = synth::render(s);
  const cv::Mat1b mask = synth::id_mask(r, 1);
  const EntityEstimate empty = estimate_entity(r.frame, Mask{"box", cv::Mat1b::zeros(480, 640), 1.0});
  EXPECT_EQ(empty.confidence, 0.0);
  EXPECT_EQ(empty.points, 0u);
  r.frame.depth.setTo(0, mask);
  EXPECT_EQ(estimate_entity(r.frame, Mask{"box", mask, 1.0}).confidence, 0.0);
}

TEST(Estimate, BatchKeepsOrderStampAndIsDeterministic) {
  Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.boxes = {Box{Eigen::Vector3d(-0.1, 0.0, 0.03), 0.2, Eigen::Vector3d(0.06, 0.06, 0.06), {200, 40, 40}},
             Box{Eigen::Vector3d(0.1, 0.05, 0.05), 0.0, Eigen::Vector3d(0.05, 0.1, 0.1), {40, 200, 40}}};
  Rendered r = synth::render(s, synth::Noise{0, 0, 2.0, 0.02, 3});
  r.frame.stamp_s = 12.5;
  const std::vector<Mask> masks{{"b", synth::id_mask(r, 2), 0.8}, {"a", synth::id_mask(r, 1), 1.0}};
  const auto first = estimate_entities(r.frame, masks);
  const auto again = estimate_entities(r.frame, masks);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_EQ(first[0].entity, "b");
  EXPECT_EQ(first[1].entity, "a");
  EXPECT_EQ(first[0].stamp_s, 12.5);
  EXPECT_LT((first[0].centroid - s.boxes[1].centre).norm(), 0.004);  // depth noise 2 mm, 2 % dropout
  EXPECT_LT((first[1].centroid - s.boxes[0].centre).norm(), 0.004);
  EXPECT_LE(first[0].confidence, 0.8);  // bounded by the mask's score
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(first[i].centroid, again[i].centroid);
    EXPECT_EQ(first[i].points, again[i].points);
    EXPECT_EQ(first[i].confidence, again[i].confidence);
  }
}

TEST(FitBox, PcaBoxOfAnElongatedCloud) {
  std::vector<Eigen::Vector3d> pts;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::Vector3d c(0.2, -0.1, 0.3);
  for (int i = -20; i <= 20; ++i)
    for (int j = -5; j <= 5; ++j)
      for (int k = -2; k <= 2; ++k) pts.push_back(c + R * Eigen::Vector3d(0.01 * i, 0.01 * j, 0.01 * k));
  const OrientedBox b = fit_box(pts, BoxFit::pca);
  EXPECT_LT((b.centre - c).norm(), 1e-9);
  EXPECT_NEAR(b.size.x(), 0.40, 1e-9);
  EXPECT_NEAR(b.size.y(), 0.10, 1e-9);
  EXPECT_NEAR(b.size.z(), 0.04, 1e-9);
  EXPECT_NEAR(std::abs(b.axes.col(0).dot(R.col(0))), 1.0, 1e-9);
  EXPECT_NEAR(b.axes.determinant(), 1.0, 1e-9);
  EXPECT_THROW(fit_box({}, BoxFit::upright), std::invalid_argument);
}

}  // namespace
}  // namespace dh::perception
