// The PCL-free stages: back-projection and the oriented box.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "back_project_impl.hpp"
#include "dh/perception/estimate.hpp"

namespace dh::perception {

BackProjection back_project(const RgbdFrame& frame, const cv::Mat1b& mask, const CloudParams& params) {
  BackProjection out;
  const detail::PixelCounts c =
      detail::back_project_each(frame, mask, params, [&](const Eigen::Vector3d& p) { out.points.push_back(p); });
  out.mask_px = c.mask_px;
  out.valid_px = c.valid_px;
  return out;
}

namespace {

/// Flips `v` so that its largest-magnitude component is positive (a deterministic sign for an axis).
Eigen::Vector3d canonical_sign(const Eigen::Vector3d& v) {
  Eigen::Index i = 0;
  v.cwiseAbs().maxCoeff(&i);
  return v[i] < 0 ? Eigen::Vector3d(-v) : v;
}

OrientedBox extents_along(const std::vector<Eigen::Vector3d>& points, const Eigen::Matrix3d& axes,
                          const Eigen::Vector3d& origin) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d q = axes.transpose() * (p - origin);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  OrientedBox box;
  box.axes = axes;
  box.size = hi - lo;
  box.centre = origin + axes * (0.5 * (lo + hi));
  return box;
}

}  // namespace

OrientedBox fit_box(const std::vector<Eigen::Vector3d>& points, BoxFit fit) {
  if (points.empty()) throw std::invalid_argument("fit_box: no points");
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());

  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  if (fit == BoxFit::upright) {
    // Minimum-area rectangle of the footprint (relative to the mean, for float precision).
    std::vector<cv::Point2f> xy;
    xy.reserve(points.size());
    for (const Eigen::Vector3d& p : points)
      xy.emplace_back(static_cast<float>(p.x() - mean.x()), static_cast<float>(p.y() - mean.y()));
    const cv::RotatedRect r = cv::minAreaRect(xy);
    cv::Point2f corner[4];
    r.points(corner);
    const Eigen::Vector2d e1(corner[1].x - corner[0].x, corner[1].y - corner[0].y);
    const Eigen::Vector2d e2(corner[2].x - corner[1].x, corner[2].y - corner[1].y);
    Eigen::Vector2d dir = e1.norm() >= e2.norm() ? e1 : e2;
    if (dir.norm() < 1e-12) dir = Eigen::Vector2d::UnitX();
    dir.normalize();
    const Eigen::Vector3d x = canonical_sign(Eigen::Vector3d(dir.x(), dir.y(), 0));
    axes.col(0) = x;
    axes.col(2) = Eigen::Vector3d::UnitZ();
    axes.col(1) = axes.col(2).cross(x);
  } else {
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& p : points) cov += (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);  // eigenvalues ascending
    const Eigen::Vector3d x = canonical_sign(eig.eigenvectors().col(2));
    const Eigen::Vector3d y = canonical_sign(eig.eigenvectors().col(1));
    axes.col(0) = x;
    axes.col(1) = y;
    axes.col(2) = x.cross(y);
  }
  return extents_along(points, axes, mean);
}

}  // namespace dh::perception
