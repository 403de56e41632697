#include "dh/perception/scene_entities.hpp"

#include <algorithm>
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/maximum_weighted_matching.hpp>
#include <opencv2/imgproc.hpp>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>
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

/// An object's candidate that passes the match, and how well it fits the object, in [0, 1].
struct Option {
  std::size_t object = 0, candidate = 0;
  double quality = 0;
};

/// Two estimates of one thing: the centre of either lies over the other's footprint (two things side by
/// side each have their centre beyond the other's edge).
bool same_box(const EntityEstimate& a, const EntityEstimate& b) {
  const auto over = [](const EntityEstimate& box, const Eigen::Vector3d& p) {
    const Eigen::Vector3d d = p - box.centroid;
    return std::abs(d.dot(box.axes.col(0))) <= box.size.x() / 2 && std::abs(d.dot(box.axes.col(1))) <= box.size.y() / 2;
  };
  return over(a, b.centroid) || over(b, a.centroid);
}

/// The candidates that are one thing: the same pixels (entities of one colour), masks of which half the
/// smaller lies in the larger, or estimates (`seen`, null where none) of one thing (same_box: a cream
/// box's colour matching a yellow box's rim gives another mask of the same box). Returns each candidate's blob, the index of one of them.
std::vector<std::size_t> blobs_of(const std::vector<Mask>& candidates, const std::vector<std::pair<int, cv::Point>>& ids,
                                  const std::vector<cv::Rect>& box, const std::vector<const EntityEstimate*>& seen) {
  std::vector<std::size_t> parent(candidates.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto root = [&](std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < candidates.size(); ++i)
    for (std::size_t j = i + 1; j < candidates.size(); ++j) {
      if (root(i) == root(j)) continue;
      bool same = ids[i] == ids[j];
      if (!same && seen[i] && seen[j]) same = same_box(*seen[i], *seen[j]);
      if (!same) {
        const cv::Rect both = box[i] & box[j];
        if (both.empty()) continue;
        const int overlap = cv::countNonZero(candidates[i].pixels(both) & candidates[j].pixels(both));
        same = 2 * overlap >= std::min(ids[i].first, ids[j].first);
      }
      if (same) parent[root(j)] = root(i);
    }
  std::vector<std::size_t> blob(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) blob[i] = root(i);
  return blob;
}

/// At most one blob per object and one object per blob, the sum of the chosen fits the greatest (Boost's
/// maximum weighted matching): an object takes another's look-alike only when that one has a better
/// candidate or none. Returns the chosen options.
std::vector<Option> assign(const std::vector<Option>& options, std::size_t objects, const std::vector<std::size_t>& blob) {
  std::map<std::size_t, std::size_t> vertex_of_blob;  // objects are vertices 0..objects-1, blobs follow
  std::map<std::pair<std::size_t, std::size_t>, const Option*> best;  // per (object, blob)
  for (const Option& o : options) {
    vertex_of_blob.try_emplace(blob[o.candidate], objects + vertex_of_blob.size());
    const Option*& b = best[{o.object, blob[o.candidate]}];
    if (!b || o.quality > b->quality) b = &o;
  }
  using Graph = boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS, boost::no_property,
                                      boost::property<boost::edge_weight_t, long>>;
  Graph g(objects + vertex_of_blob.size());
  // Even integer weights keep the matching's dual variables whole.
  for (const auto& [key, o] : best)
    if (const long w = 2 * std::lround(1e4 * o->quality); w > 0) boost::add_edge(key.first, vertex_of_blob.at(key.second), w, g);
  std::vector<Graph::vertex_descriptor> mate(boost::num_vertices(g));
  boost::maximum_weighted_matching(g, mate.data());
  std::vector<Option> chosen;
  for (const auto& [key, o] : best)
    if (mate[key.first] == vertex_of_blob.at(key.second)) chosen.push_back(*o);
  return chosen;
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
  // known by its pixel count and its first pixel, and each distinct one is estimated once.
  using Id = std::pair<int, cv::Point>;
  // Its pixels' bounding box comes from the same scan (blobs_of compares only masks whose boxes meet).
  std::vector<Id> ids;
  std::vector<cv::Rect> box;
  for (const auto& m : candidates) {
    std::vector<cv::Point> nz;
    cv::findNonZero(m.pixels, nz);
    ids.emplace_back(static_cast<int>(nz.size()), nz.empty() ? cv::Point(-1, -1) : nz.front());
    box.push_back(cv::boundingRect(nz));
  }
  const auto before = [](const Id& a, const Id& b) {
    return std::tie(a.first, a.second.y, a.second.x) < std::tie(b.first, b.second.y, b.second.x);
  };
  std::map<Id, EntityEstimate, decltype(before)> estimated(before);
  const auto bottom = [](const EntityEstimate& x) { return x.centroid.z() - x.size.z() / 2; };
  // How well a box fits an object: 1 at its size, 0 at the most mismatch `match` allows, negative past
  // it. The mask's score is left out: a grown seed is a patch of the support by construction.
  const auto quality = [&](const LookFor& o, const EntityEstimate& e) {
    const double limit = match.max_size_mismatch * o.size.sum();
    return 1 - size_mismatch(e.size, o.size) / limit;
  };

  // Each object's largest max_candidates that pass `match`, with how well each fits it.
  std::vector<Option> options;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    std::size_t tried = 0;
    for (std::size_t i = 0; i < candidates.size() && tried < match.max_candidates; ++i) {
      const Mask& m = candidates[i];
      if (m.entity != objects[k].appearance.entity) continue;
      ++tried;
      auto cached = estimated.find(ids[i]);
      if (cached == estimated.end()) cached = estimated.emplace(ids[i], estimate_entity(frame, m, params)).first;
      const EntityEstimate& e = cached->second;
      if (e.confidence <= 0 || bottom(e) > match.max_bottom_z_m) continue;
      if (const double q = quality(objects[k], e); q >= 0) options.push_back({k, i, q});
    }
  }
  std::vector<const EntityEstimate*> seen(candidates.size(), nullptr);
  for (const Option& o : options) seen[o.candidate] = &estimated.at(ids[o.candidate]);
  const std::vector<std::size_t> blob = blobs_of(candidates, ids, box, seen);
  std::vector<EntityEstimate> out(objects.size());
  for (std::size_t k = 0; k < objects.size(); ++k) {
    out[k].entity = objects[k].appearance.entity;
    out[k].stamp_s = frame.stamp_s;
  }
  std::vector<bool> taken(candidates.size(), false);  // by blob
  for (const Option& o : assign(options, objects.size(), blob)) {
    out[o.object] = estimated.at(ids[o.candidate]);
    out[o.object].entity = objects[o.object].appearance.entity;
    taken[blob[o.candidate]] = true;
  }

  // An object none of whose candidates has its size may be one whose colour matched only its lit faces
  // (white and grey walls render as grey as the floor and the shadows): with a known support, its
  // candidates not taken grow over the depth image into what stands above the support, in the objects'
  // order after every object seen as it is has been placed; the one closest to its size wins.
  std::vector<std::pair<std::pair<Id, Eigen::Vector3d>, EntityEstimate>> grown;
  for (std::size_t k = 0; k < objects.size() && params.support_z; ++k) {
    if (out[k].confidence > 0) continue;
    const LookFor& o = objects[k];
    GrowParams g;
    g.support_z = *params.support_z;
    // What of the seed lies higher than the object standing on its support can reach is something else
    // (a robot link the colour mask joined) and is dropped; a seed too small to estimate (a rim) grows.
    g.max_height_m = o.size.z() + match.seed_margin_m;
    g.max_radius_m = 0.5 * std::hypot(o.size.x(), o.size.y()) + match.grow_margin_m;
    g.min_depth_m = params.min_depth_m;
    g.max_depth_m = params.max_depth_m;
    std::optional<std::size_t> best;
    double best_quality = -1;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const Mask& m = candidates[i];
      if (m.entity != o.appearance.entity || taken[blob[i]]) continue;
      // Identical objects grow the same candidates alike: each (candidate, size) is grown once.
      auto done = std::find_if(grown.begin(), grown.end(), [&](const auto& x) { return x.first == std::pair(ids[i], o.size); });
      if (done == grown.end()) {
        const cv::Mat1b mask = grow_by_depth(frame, m.pixels, g);
        grown.emplace_back(std::pair(ids[i], o.size), cv::countNonZero(mask) > 0
                                                          ? estimate_entity(frame, Mask{m.entity, mask, m.score}, params)
                                                          : EntityEstimate{});
        done = std::prev(grown.end());
      }
      const EntityEstimate& e = done->second;
      // Grown, it must reach down to what holds it: a robot link or a fixture's rim stands higher. Nor
      // may it grow into an object already placed (a cream box's candidate into the yellow box beside
      // its own colour's pixels).
      if (e.confidence <= 0 || bottom(e) > g.support_z + match.grown_max_bottom_m ||
          std::any_of(out.begin(), out.end(), [&](const EntityEstimate& x) { return x.confidence > 0 && same_box(x, e); }))
        continue;
      if (const double q = quality(o, e); q >= 0 && q > best_quality) {
        best_quality = q;
        best = i;
        out[k] = e;
        out[k].entity = o.appearance.entity;
      }
    }
    if (best) taken[blob[*best]] = true;
  }
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
