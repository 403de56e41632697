#include "dh/perception/scene_entities.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

namespace dh::perception {

namespace {

cv::Vec3b to_rgb8(const std::array<double, 4>& rgba) {
  const auto c = [](double v) { return static_cast<unsigned char>(std::clamp(v, 0.0, 1.0) * 255.0 + 0.5); };
  return {c(rgba[0]), c(rgba[1]), c(rgba[2])};
}

/// The upright bounding box of an asset's geoms in its body frame (full extents).
Eigen::Vector3d asset_size(const sim::AssetSpec& asset) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  for (const auto& g : asset.geoms) {
    Eigen::Vector3d half;
    if (g.type == sim::GeomSpec::Type::Box) {
      // A box turned about z covers its turned corners.
      const double c = std::abs(std::cos(g.yaw)), s = std::abs(std::sin(g.yaw));
      half = {c * g.size[0] + s * g.size[1], s * g.size[0] + c * g.size[1], g.size[2]};
    } else if (g.type == sim::GeomSpec::Type::Ring) {
      half = {g.size[0], g.size[0], g.size[2]};
    } else {  // cylinder, disc: radius, half height
      half = {g.size[0], g.size[0], g.size[1]};
    }
    const Eigen::Vector3d centre(g.pos[0], g.pos[1], g.pos[2]);
    lo = lo.cwiseMin(centre - half);
    hi = hi.cwiseMax(centre + half);
  }
  return asset.geoms.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(hi - lo);
}

/// How far a box's extents are from the expected ones: horizontal extents compared largest with largest
/// (an estimate's x axis follows the longer side), height with height; metres.
double size_mismatch(const Eigen::Vector3d& estimated, const Eigen::Vector3d& expected) {
  const double e0 = std::max(estimated.x(), estimated.y()), e1 = std::min(estimated.x(), estimated.y());
  const double x0 = std::max(expected.x(), expected.y()), x1 = std::min(expected.x(), expected.y());
  return std::abs(e0 - x0) + std::abs(e1 - x1) + std::abs(estimated.z() - expected.z());
}

}  // namespace

std::vector<LookFor> free_objects(const sim::SceneSpec& scene) {
  std::vector<LookFor> out;
  for (const auto& e : scene.entities) {
    if (e.fixture()) continue;
    LookFor o;
    o.size = asset_size(e.asset);
    // 600 px focal length, 0.8 m away: the most pixels the object can cover in the workcell view.
    const double span_px = 600.0 * o.size.norm() / 0.8;
    o.appearance = {e.name, {to_rgb8(e.rgba)}, 40, span_px * span_px};
    for (const auto& g : e.asset.geoms)
      if (g.rgba) {
        const cv::Vec3b c = to_rgb8(*g.rgba);
        auto& rgb = o.appearance.rgb;
        if (std::find(rgb.begin(), rgb.end(), c) == rgb.end()) rgb.push_back(c);
      }
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<EntityAppearance> appearances(const std::vector<LookFor>& objects) {
  std::vector<EntityAppearance> out;
  for (const auto& o : objects) out.push_back(o.appearance);
  return out;
}

std::vector<EntityEstimate> estimate_objects(const RgbdFrame& frame, const std::vector<Mask>& candidates,
                                             const std::vector<LookFor>& objects, const CloudParams& params,
                                             const ObjectMatch& match) {
  // Candidates are per entity; entities of the same colours got the same pixels, so a candidate is
  // known by its pixel count and its first pixel, and each distinct one is identified and estimated once.
  using Id = std::pair<int, cv::Point>;
  const auto identity = [](const Mask& m) {
    std::vector<cv::Point> nz;
    cv::findNonZero(m.pixels, nz);
    return Id(static_cast<int>(nz.size()), nz.empty() ? cv::Point(-1, -1) : nz.front());
  };
  std::vector<Id> ids;
  ids.reserve(candidates.size());
  for (const auto& m : candidates) ids.push_back(identity(m));
  const auto before = [](const Id& a, const Id& b) {
    return std::tie(a.first, a.second.y, a.second.x) < std::tie(b.first, b.second.y, b.second.x);
  };
  std::map<Id, EntityEstimate, decltype(before)> estimated(before);
  std::vector<Id> taken;
  std::vector<EntityEstimate> out;
  for (const auto& o : objects) {
    EntityEstimate best;
    best.entity = o.appearance.entity;
    best.stamp_s = frame.stamp_s;
    double best_mismatch = 1e9;
    Id best_id;
    std::size_t tried = 0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Mask& m = candidates[i];
      if (m.entity != o.appearance.entity || tried == match.max_candidates) continue;
      const Id& id = ids[i];
      if (std::find(taken.begin(), taken.end(), id) != taken.end()) continue;
      ++tried;
      auto cached = estimated.find(id);
      if (cached == estimated.end()) cached = estimated.emplace(id, estimate_entity(frame, m, params)).first;
      EntityEstimate e = cached->second;
      e.entity = m.entity;
      if (e.confidence <= 0 || e.centroid.z() - e.size.z() / 2 > match.max_bottom_z_m) continue;
      const double mismatch = size_mismatch(e.size, o.size);
      if (mismatch < best_mismatch) {
        best_mismatch = mismatch;
        best = e;
        best_id = id;
      }
    }
    if (best.confidence > 0 && best_mismatch > match.max_size_mismatch * o.size.sum()) best.confidence = 0;
    if (best.confidence > 0) taken.push_back(best_id);
    out.push_back(best);
  }
  return out;
}

}  // namespace dh::perception
