#include "dh/perception/scene_entities.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "dh/perception/grow.hpp"

namespace dh::perception {

namespace {

cv::Vec3b to_rgb8(const std::array<double, 4>& rgba) {
  const auto c = [](double v) { return static_cast<unsigned char>(std::clamp(v, 0.0, 1.0) * 255.0 + 0.5); };
  return {c(rgba[0]), c(rgba[1]), c(rgba[2])};
}

/// A geom as a box in its body's frame (a cylinder, disc or ring as its bounding box).
BodyBox body_box(const sim::GeomSpec& g) {
  BodyBox b;
  b.centre = {g.pos[0], g.pos[1], g.pos[2]};
  b.yaw = g.yaw;
  if (g.type == sim::GeomSpec::Type::Box)
    b.half = {g.size[0], g.size[1], g.size[2]};
  else if (g.type == sim::GeomSpec::Type::Ring)
    b.half = {g.size[0], g.size[0], g.size[2]};
  else
    b.half = {g.size[0], g.size[0], g.size[1]};
  return b;
}

/// The upright bounding box of an asset's geoms in its body frame (full extents).
Eigen::Vector3d asset_size(const sim::AssetSpec& asset) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = Eigen::Vector3d::Constant(-1e9);
  for (const auto& g : asset.geoms) {
    const BodyBox b = body_box(g);
    Eigen::Vector3d half = b.half;
    if (g.type == sim::GeomSpec::Type::Box) {
      // A box turned about z covers its turned corners (round geoms are the same turned).
      const double c = std::abs(std::cos(b.yaw)), s = std::abs(std::sin(b.yaw));
      half = {c * b.half.x() + s * b.half.y(), s * b.half.x() + c * b.half.y(), b.half.z()};
    }
    lo = lo.cwiseMin(b.centre - half);
    hi = hi.cwiseMax(b.centre + half);
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
    o.prior_xy = Eigen::Vector2d(e.nominal_xy[0], e.nominal_xy[1]);
    o.identity = {e.asset.kind, e.asset.category, e.colour};
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

std::vector<PartModel> articulated_parts(const sim::SceneSpec& scene) {
  std::vector<PartModel> out;
  // The table's top is at z = 0.
  BodyBox table;
  table.half = {scene.table_size[0] / 2, scene.table_size[1] / 2, scene.table_size[2] / 2};
  table.centre = {0, 0, -table.half.z()};
  for (const auto& e : scene.entities) {
    if (!e.fixture() || e.asset.parts.empty()) continue;
    const Eigen::Isometry3d world_from_fixture =
        Eigen::Translation3d(e.nominal_xy[0], e.nominal_xy[1], 0) * Eigen::AngleAxisd(e.yaw, Eigen::Vector3d::UnitZ());
    std::vector<BodyBox> still{table};
    for (const auto& g : e.asset.geoms) {
      // The body's boxes in the world: its turn and place applied to the box's centre and yaw.
      BodyBox b = body_box(g);
      b.centre = world_from_fixture * b.centre;
      b.yaw += e.yaw;
      still.push_back(b);
    }
    for (const auto& part : e.asset.parts) {
      PartModel m;
      m.name = sim::part_body(e.name, part.name);
      m.kind = part.kind;
      m.world_from_rest = world_from_fixture * Eigen::Translation3d(part.pos[0], part.pos[1], part.pos[2]);
      m.joint = part.joint.type == sim::JointSpec::Type::Slide ? PartModel::Joint::Slide : PartModel::Joint::Hinge;
      m.axis = Eigen::Vector3d(part.joint.axis[0], part.joint.axis[1], part.joint.axis[2]).normalized();
      m.lo = part.joint.range[0];
      m.hi = part.joint.range[1];
      for (const auto& g : part.geoms) m.boxes.push_back(body_box(g));
      m.still = still;
      m.riders.push_back({m.name, Eigen::Vector3d(part.grip.pos[0], part.grip.pos[1], part.grip.pos[2])});
      for (const auto& s : part.sites)
        m.riders.push_back({e.name + "_" + s.name, Eigen::Vector3d(s.pos[0], s.pos[1], s.pos[2])});
      out.push_back(std::move(m));
    }
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
  std::vector<std::pair<std::pair<Id, Eigen::Vector3d>, EntityEstimate>> grown;
  // The object's candidate closest to its size, among its largest max_candidates not taken; `grow` tries
  // every candidate not taken, grown over the depth image (see below). confidence 0 when none passes `match`.
  const auto choose = [&](const LookFor& o, bool grow) {
    EntityEstimate best;
    best.entity = o.appearance.entity;
    best.stamp_s = frame.stamp_s;
    double best_mismatch = 1e9;
    Id best_id;
    std::size_t tried = 0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Mask& m = candidates[i];
      if (m.entity != o.appearance.entity || (!grow && tried == match.max_candidates)) continue;
      const Id& id = ids[i];
      if (std::find(taken.begin(), taken.end(), id) != taken.end()) continue;
      ++tried;
      const auto bottom = [](const EntityEstimate& x) { return x.centroid.z() - x.size.z() / 2; };
      EntityEstimate e;
      if (!grow) {
        auto cached = estimated.find(id);
        if (cached == estimated.end())
          cached = estimated.emplace(id, estimate_entity(frame, m, params)).first;
        e = cached->second;
        if (e.confidence <= 0 || bottom(e) > match.max_bottom_z_m) continue;
      } else {
        // What of the seed lies higher than the object standing on its support can reach is something else
        // (a robot link the colour mask joined) and is dropped; a seed too small to estimate (a rim) grows.
        GrowParams g;
        g.support_z = *params.support_z;
        g.max_height_m = o.size.z() + match.seed_margin_m;
        g.max_radius_m = 0.5 * std::hypot(o.size.x(), o.size.y()) + match.grow_margin_m;
        g.min_depth_m = params.min_depth_m;
        g.max_depth_m = params.max_depth_m;
        // Identical objects grow the same candidates alike: each (candidate, size) is grown once.
        auto done = std::find_if(grown.begin(), grown.end(),
                                 [&](const auto& x) { return x.first == std::pair(id, o.size); });
        if (done == grown.end()) {
          const cv::Mat1b mask = grow_by_depth(frame, m.pixels, g);
          grown.emplace_back(std::pair(id, o.size),
                             cv::countNonZero(mask) > 0
                                 ? estimate_entity(frame, Mask{m.entity, mask, m.score}, params)
                                 : EntityEstimate{});
          done = std::prev(grown.end());
        }
        e = done->second;
        // Grown, it must reach down to what holds it: a robot link or a fixture's rim stands higher.
        if (e.confidence <= 0 || bottom(e) > g.support_z + match.grown_max_bottom_m) continue;
      }
      e.entity = m.entity;
      const double mismatch = size_mismatch(e.size, o.size);
      if (mismatch < best_mismatch) {
        best_mismatch = mismatch;
        best = e;
        best_id = id;
      }
    }
    if (best.confidence > 0 && best_mismatch > match.max_size_mismatch * o.size.sum()) best.confidence = 0;
    if (best.confidence > 0) taken.push_back(best_id);
    return best;
  };
  std::vector<EntityEstimate> out;
  for (const auto& o : objects) out.push_back(choose(o, false));
  // An object none of whose candidates has its size may be one whose colour matched only its lit faces
  // (white and grey walls render as grey as the floor and the shadows): its candidates grow over the depth
  // image into what stands above the known support, after every object seen as it is has chosen.
  if (params.support_z)
    for (std::size_t k = 0; k < objects.size(); ++k)
      if (out[k].confidence <= 0) out[k] = choose(objects[k], true);
  // Identical objects (same colours, same size) are told apart by where they are expected (pairwise: a
  // cycle of three that no exchange of two improves stays; no scene has three identical objects). Two seen
  // trade estimates when that lowers the sum of their distances to their priors; one seen goes to the
  // object whose prior is nearer, so an object the hand hides does not lend its name to its twin.
  const auto d = [](const EntityEstimate& e, const Eigen::Vector2d& xy) {
    return (e.centroid.head<2>() - xy).norm();
  };
  for (std::size_t i = 0; i < objects.size(); ++i)
    for (std::size_t j = i + 1; j < objects.size(); ++j) {
      const LookFor &a = objects[i], &b = objects[j];
      const bool seen_i = out[i].confidence > 0, seen_j = out[j].confidence > 0;
      if (!a.prior_xy || !b.prior_xy || (!seen_i && !seen_j) || a.appearance.rgb != b.appearance.rgb ||
          !a.size.isApprox(b.size, 1e-9))
        continue;
      const bool trade = seen_i && seen_j ? d(out[j], *a.prior_xy) + d(out[i], *b.prior_xy) <
                                                d(out[i], *a.prior_xy) + d(out[j], *b.prior_xy)
                         : seen_i ? d(out[i], *b.prior_xy) < d(out[i], *a.prior_xy)
                                  : d(out[j], *a.prior_xy) < d(out[j], *b.prior_xy);
      if (trade) {
        std::swap(out[i], out[j]);
        std::swap(out[i].entity, out[j].entity);
      }
    }
  return out;
}

}  // namespace dh::perception
