// From a mask and the depth image to an entity's pose and size in the world: back-projection, voxel
// grid, statistical outlier removal, support-plane removal, Euclidean clustering, oriented box.
// PCL does the filtering inside estimate.cpp; nothing here exposes it.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dh/perception/frame.hpp"
#include "dh/perception/masks.hpp"

namespace dh::perception {

struct EntityEstimate {
  std::string entity;
  /// The centre of the oriented box (world, m): not the mean of the points, which a camera seeing only
  /// the near faces pulls towards itself.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  /// Columns: the box axes in the world, right-handed; x along the longer horizontal side, z up (upright
  /// box) or the principal axes by decreasing variance (PCA box).
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  ///< box extents along the axes, m
  /// In [0, 1]; 0 means no estimate (too few points) and then centroid, axes and size are meaningless.
  double confidence = 0;
  std::size_t points = 0;  ///< points in the kept cluster (after the voxel grid)
  double stamp_s = 0;      ///< the frame's stamp
  /// The box's x axis turned about world z (rad): the yaw the scene topic and the perceived world carry.
  double yaw() const { return std::atan2(axes(1, 0), axes(0, 0)); }
};

enum class BoxFit {
  upright,  ///< z = world up; the horizontal footprint is the minimum-area rectangle of the points
  pca,      ///< the principal axes of the points' covariance
};

/// Defaults for a 640x480 RealSense-class camera 0.5-1.5 m from a tabletop with objects 3-30 cm across;
/// the reasons are in services/perception/README.md ("CloudParams").
struct CloudParams {
  double min_depth_m = 0.15;  ///< nearer readings are invalid (D4xx minimum range)
  double max_depth_m = 3.0;   ///< farther readings are invalid (depth error grows with z^2)
  int mask_erode_px = 0;      ///< erode the mask first (pixels): 1-2 for a camera whose depth and colour
                              ///< edges disagree; each pixel shrinks the box by a pixel's footprint
  double voxel_m = 0.005;     ///< voxel grid leaf, m; 0 = none
  int outlier_k = 12;         ///< statistical outlier removal: neighbours; 0 = none
  double outlier_stddev = 2.5;  ///< ... and the threshold in standard deviations of the mean distance
  bool remove_plane = true;
  /// The support surface's height when it is known (a calibrated table; the simulated workcell's top is at
  /// z = 0): points up to plane_distance_m above it go and boxes extend down to it, without RANSAC. Unset:
  /// the support plane is searched in each mask's points (which can take a thin object's own top face).
  std::optional<double> support_z;
  double plane_distance_m = 0.005;   ///< RANSAC inlier distance
  double plane_max_tilt_deg = 8.0;   ///< a support plane's normal is this close to world z
  double plane_min_fraction = 0.25;  ///< a support plane holds at least this share of the points ...
  double plane_max_below_fraction = 0.05;  ///< ... has at most this share below it ...
  std::size_t plane_min_above = 30;        ///< ... and at least this many points above it
  int plane_iterations = 200;
  double cluster_tolerance_m = 0.012;  ///< Euclidean clustering neighbour distance (about 2.5 voxels)
  std::size_t min_points = 15;         ///< fewer points in the kept cluster: confidence 0
  BoxFit box = BoxFit::upright;
};

/// Estimates the entity of `mask` (frame-sized) in `frame`. Throws std::invalid_argument on a bad frame
/// or a mask of another size; an empty or depth-less mask gives confidence 0.
/// Confidence = mask score (clamped to [0,1]) x valid-depth share of the mask's pixels x share of the
/// filtered points in the kept cluster (see the README).
EntityEstimate estimate_entity(const RgbdFrame& frame, const Mask& mask, const CloudParams& params = {});
/// One estimate per mask, in the masks' order.
std::vector<EntityEstimate> estimate_entities(const RgbdFrame& frame, const std::vector<Mask>& masks,
                                              const CloudParams& params = {});

// ---- The stages, on plain points (world, m), for tests and tools. estimate_entity runs the same code
// ---- on PCL clouds without these conversions.

struct BackProjection {
  std::vector<Eigen::Vector3d> points;  ///< world frame
  std::size_t mask_px = 0;              ///< pixels in the (eroded) mask
  std::size_t valid_px = 0;             ///< of those, with depth in [min_depth_m, max_depth_m]
};
/// Back-projects the mask's pixels with valid depth to world points (row-major pixel order).
BackProjection back_project(const RgbdFrame& frame, const cv::Mat1b& mask, const CloudParams& params = {});

std::vector<Eigen::Vector3d> voxel_filter(const std::vector<Eigen::Vector3d>& points, double leaf_m);
std::vector<Eigen::Vector3d> remove_outliers(const std::vector<Eigen::Vector3d>& points, int k, double stddev);

struct PlaneRemoval {
  std::vector<Eigen::Vector3d> kept;  ///< everything when no support plane was found
  bool removed = false;
  Eigen::Vector4d plane = Eigen::Vector4d::Zero();  ///< (n, d), n.p + d = 0, n up; when removed
};
/// Removes the support plane: the largest plane within plane_max_tilt_deg of horizontal, taken as a
/// support only when it holds plane_min_fraction of the points, at most plane_max_below_fraction lie
/// below it and plane_min_above lie above it (so a box's top face or a plate alone is never removed).
/// Points on or below the plane go.
PlaneRemoval remove_support_plane(const std::vector<Eigen::Vector3d>& points, const CloudParams& params);

/// Euclidean clusters (min size 1), largest first.
std::vector<std::vector<Eigen::Vector3d>> euclidean_clusters(const std::vector<Eigen::Vector3d>& points,
                                                             double tolerance_m);

struct OrientedBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
};
/// The box enclosing all points, oriented by `fit`. Throws std::invalid_argument on no points.
OrientedBox fit_box(const std::vector<Eigen::Vector3d>& points, BoxFit fit);

}  // namespace dh::perception
