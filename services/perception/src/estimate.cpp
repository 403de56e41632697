// The PCL stages (voxel grid, statistical outlier removal, support-plane RANSAC, Euclidean clustering)
// and the estimate pipeline. The only file of the project that includes PCL.
#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/console/print.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <unordered_set>

#include "back_project_impl.hpp"
#include "dh/perception/estimate.hpp"

namespace dh::perception {

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

Cloud::Ptr to_cloud(const std::vector<Eigen::Vector3d>& points) {
  Cloud::Ptr c(new Cloud);
  c->reserve(points.size());
  for (const Eigen::Vector3d& p : points)
    c->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  return c;
}

std::vector<Eigen::Vector3d> to_points(const Cloud& c) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(c.size());
  for (const pcl::PointXYZ& p : c) out.emplace_back(p.x, p.y, p.z);
  return out;
}

Cloud::Ptr voxel(const Cloud::Ptr& in, double leaf) {
  if (!(leaf > 0) || in->empty()) return in;
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(in);
  const float l = static_cast<float>(leaf);
  grid.setLeafSize(l, l, l);
  Cloud::Ptr out(new Cloud);
  grid.filter(*out);
  return out;
}

Cloud::Ptr outliers(const Cloud::Ptr& in, int k, double stddev) {
  if (k <= 0 || in->size() <= static_cast<std::size_t>(k)) return in;
  pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
  sor.setInputCloud(in);
  sor.setMeanK(k);
  sor.setStddevMulThresh(stddev);
  Cloud::Ptr out(new Cloud);
  sor.filter(*out);
  return out;
}

struct PlaneResult {
  Cloud::Ptr kept;
  bool removed = false;
  Eigen::Vector4d plane = Eigen::Vector4d::Zero();
};

/// PCL prints "RANSAC found no model" and the like on stderr: routine here (most masks hold no plane).
void quiet_pcl() {
  static std::once_flag once;
  std::call_once(once, [] { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); });
}

PlaneResult support_plane(const Cloud::Ptr& in, const CloudParams& p) {
  quiet_pcl();
  PlaneResult r{in, false, Eigen::Vector4d::Zero()};
  if (in->size() < 10) return r;
  pcl::SACSegmentation<pcl::PointXYZ> seg;  // fixed seed: deterministic
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(p.plane_max_tilt_deg * M_PI / 180.0);
  seg.setDistanceThreshold(p.plane_distance_m);
  seg.setMaxIterations(p.plane_iterations);
  seg.setInputCloud(in);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coeff;
  seg.segment(inliers, coeff);
  if (inliers.indices.empty() || coeff.values.size() != 4) return r;
  Eigen::Vector4d plane(coeff.values[0], coeff.values[1], coeff.values[2], coeff.values[3]);
  const double norm = plane.head<3>().norm();
  if (!(norm > 0)) return r;
  plane /= norm;
  if (plane[2] < 0) plane = -plane;  // normal up
  // Optimising the coefficients may tilt the plane past the limit: check again.
  if (plane[2] < std::cos(p.plane_max_tilt_deg * M_PI / 180.0)) return r;
  const double n = static_cast<double>(in->size());
  if (static_cast<double>(inliers.indices.size()) < p.plane_min_fraction * n) return r;
  const double margin = 2 * p.plane_distance_m;
  std::size_t below = 0, above = 0;
  for (const pcl::PointXYZ& q : *in) {
    const double d = plane[0] * q.x + plane[1] * q.y + plane[2] * q.z + plane[3];
    if (d < -margin) ++below;
    if (d > margin) ++above;
  }
  if (static_cast<double>(below) > p.plane_max_below_fraction * n || above < p.plane_min_above) return r;
  Cloud::Ptr kept(new Cloud);
  kept->reserve(above);
  for (const pcl::PointXYZ& q : *in)
    if (plane[0] * q.x + plane[1] * q.y + plane[2] * q.z + plane[3] > p.plane_distance_m) kept->push_back(q);
  r.kept = kept;
  r.removed = true;
  r.plane = plane;
  return r;
}

/// The known support surface z = `z` taken as the plane: the points more than `distance` above it stay.
PlaneResult known_support(const Cloud::Ptr& in, double z, double distance) {
  Cloud::Ptr kept(new Cloud);
  for (const pcl::PointXYZ& q : *in)
    if (q.z > z + distance) kept->push_back(q);
  return {kept, true, Eigen::Vector4d(0, 0, 1, -z)};
}

/// The voxel of a point as PCL's VoxelGrid computes it (floor of coordinate / leaf), packed in 63 bits.
/// A voxel's centroid lies inside its voxel, so it maps back to the same key.
struct VoxelKey {
  explicit VoxelKey(double leaf) : inv(1.0f / static_cast<float>(leaf)) {}  // as VoxelGrid computes it
  std::uint64_t operator()(const pcl::PointXYZ& p) const {
    const auto part = [&](float v) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v * inv)) + (1 << 20)) & 0x1FFFFF;
    };
    return part(p.x) | (part(p.y) << 21) | (part(p.z) << 42);
  }
  float inv;
};

/// Cluster indices, largest first (ties: the cluster holding the lowest point index first).
std::vector<pcl::PointIndices> clusters(const Cloud::Ptr& in, double tolerance) {
  std::vector<pcl::PointIndices> out;
  if (in->empty()) return out;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>(false));  // unsorted: faster
  tree->setInputCloud(in);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
  ec.setClusterTolerance(tolerance);
  ec.setMinClusterSize(1);
  ec.setMaxClusterSize(std::numeric_limits<int>::max());
  ec.setSearchMethod(tree);
  ec.setInputCloud(in);
  ec.extract(out);
  for (pcl::PointIndices& c : out) std::sort(c.indices.begin(), c.indices.end());
  std::stable_sort(out.begin(), out.end(), [](const pcl::PointIndices& a, const pcl::PointIndices& b) {
    if (a.indices.size() != b.indices.size()) return a.indices.size() > b.indices.size();
    return a.indices.front() < b.indices.front();
  });
  return out;
}

}  // namespace

std::vector<Eigen::Vector3d> voxel_filter(const std::vector<Eigen::Vector3d>& points, double leaf_m) {
  return to_points(*voxel(to_cloud(points), leaf_m));
}

std::vector<Eigen::Vector3d> remove_outliers(const std::vector<Eigen::Vector3d>& points, int k, double stddev) {
  return to_points(*outliers(to_cloud(points), k, stddev));
}

PlaneRemoval remove_support_plane(const std::vector<Eigen::Vector3d>& points, const CloudParams& params) {
  const PlaneResult r = support_plane(to_cloud(points), params);
  PlaneRemoval out;
  out.removed = r.removed;
  out.plane = r.plane;
  out.kept = r.removed ? to_points(*r.kept) : points;
  return out;
}

std::vector<std::vector<Eigen::Vector3d>> euclidean_clusters(const std::vector<Eigen::Vector3d>& points,
                                                             double tolerance_m) {
  const Cloud::Ptr cloud = to_cloud(points);
  std::vector<std::vector<Eigen::Vector3d>> out;
  for (const pcl::PointIndices& c : clusters(cloud, tolerance_m)) {
    out.emplace_back();
    out.back().reserve(c.indices.size());
    for (const int i : c.indices) out.back().push_back(points[static_cast<std::size_t>(i)]);
  }
  return out;
}

EntityEstimate estimate_entity(const RgbdFrame& frame, const Mask& mask, const CloudParams& params) {
  EntityEstimate est;
  est.entity = mask.entity;
  est.stamp_s = frame.stamp_s;
  Cloud::Ptr cloud(new Cloud);
  const detail::PixelCounts px = detail::back_project_each(frame, mask.pixels, params, [&](const Eigen::Vector3d& p) {
    cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  });
  if (cloud->empty()) return est;

  const Cloud::Ptr sampled = voxel(cloud, params.voxel_m);
  const Cloud::Ptr inliers = outliers(sampled, params.outlier_k, params.outlier_stddev);
  const PlaneResult plane = !params.remove_plane ? PlaneResult{inliers, false, {}}
                            : params.support_z   ? known_support(inliers, *params.support_z, params.plane_distance_m)
                                                 : support_plane(inliers, params);
  const std::vector<pcl::PointIndices> found = clusters(plane.kept, params.cluster_tolerance_m);
  if (found.empty()) return est;
  const pcl::PointIndices& kept = found.front();
  est.points = kept.indices.size();
  if (est.points < params.min_points) return est;

  // The box is fitted to the full-resolution points of the kept voxels: voxel centroids lie up to half a
  // leaf inside the surface's edges and would shrink the box by about a leaf.
  std::vector<Eigen::Vector3d> points;
  if (sampled != cloud) {
    const VoxelKey key(params.voxel_m);
    std::unordered_set<std::uint64_t> kept_voxels;
    kept_voxels.reserve(kept.indices.size() * 2);
    for (const int i : kept.indices) kept_voxels.insert(key((*plane.kept)[static_cast<std::size_t>(i)]));
    points.reserve(cloud->size());
    for (const pcl::PointXYZ& q : *cloud)
      if (kept_voxels.count(key(q))) points.emplace_back(q.x, q.y, q.z);
  }
  if (points.size() < kept.indices.size()) {  // no voxel grid (or keys lost to rounding): the cluster itself
    points.clear();
    for (const int i : kept.indices) {
      const pcl::PointXYZ& q = (*plane.kept)[static_cast<std::size_t>(i)];
      points.emplace_back(q.x, q.y, q.z);
    }
  }
  OrientedBox box = fit_box(points, params.box);
  if (plane.removed && params.box == BoxFit::upright) {
    // The entity rests on the support plane whose points went with it: extend the box down to the
    // plane under its centre, unless it hovers clearly above it (held, or on something else).
    const Eigen::Vector4d& pl = plane.plane;
    const double plane_z = -(pl[0] * box.centre.x() + pl[1] * box.centre.y() + pl[3]) / pl[2];
    const double bottom = box.centre.z() - 0.5 * box.size.z();
    const double gap = bottom - plane_z;
    if (gap > 0 && gap <= params.plane_distance_m + params.cluster_tolerance_m) {
      box.size.z() += gap;
      box.centre.z() -= 0.5 * gap;
    }
  }
  est.centroid = box.centre;
  est.axes = box.axes;
  est.size = box.size;
  const double score = std::clamp(mask.score, 0.0, 1.0);
  const double valid = px.mask_px ? static_cast<double>(px.valid_px) / static_cast<double>(px.mask_px) : 0.0;
  const double kept_share = static_cast<double>(est.points) / static_cast<double>(sampled->size());
  est.confidence = std::clamp(score * valid * kept_share, 0.0, 1.0);
  return est;
}

std::vector<EntityEstimate> estimate_entities(const RgbdFrame& frame, const std::vector<Mask>& masks,
                                              const CloudParams& params) {
  std::vector<EntityEstimate> out;
  out.reserve(masks.size());
  for (const Mask& m : masks) out.push_back(estimate_entity(frame, m, params));
  return out;
}

}  // namespace dh::perception
