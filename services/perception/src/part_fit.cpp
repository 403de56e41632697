#include "dh/perception/part_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace dh::perception {

Eigen::Isometry3d PartModel::world_from_part(double q) const {
  Eigen::Isometry3d t = world_from_rest;
  if (joint == Joint::Slide)
    t.translate(q * axis);
  else
    t.rotate(Eigen::AngleAxisd(q, axis));
  return t;
}

namespace {

/// A box in the frame the points are given in: the inverse of its placement.
struct PlacedBox {
  Eigen::Isometry3d box_from_frame;
  Eigen::Vector3d half;
};

PlacedBox place(const BodyBox& b, const Eigen::Isometry3d& frame_from_body) {
  Eigen::Isometry3d frame_from_box = frame_from_body;
  frame_from_box.translate(b.centre);
  frame_from_box.rotate(Eigen::AngleAxisd(b.yaw, Eigen::Vector3d::UnitZ()));
  return {frame_from_box.inverse(), b.half};
}

/// The point is on the box's faces (within `tol` outside or inside it) or deeper inside.
enum class Where { Away, Surface, Deep };
Where where(const PlacedBox& b, const Eigen::Vector3d& p, double tol) {
  const Eigen::Vector3d d = (b.box_from_frame * p).cwiseAbs() - b.half;
  const double outside = d.cwiseMax(0.0).norm();
  if (outside > tol) return Where::Away;
  if (outside > 0) return Where::Surface;
  return -d.maxCoeff() <= tol ? Where::Surface : Where::Deep;
}

/// Where the segment from `o` to `o + d` enters the axis-aligned box [lo, hi], as a share of its length
/// (0 when it starts inside); nullopt when it misses the box (the slab test).
std::optional<double> entry(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
                            const Eigen::Vector3d& hi) {
  double t0 = 0, t1 = 1;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < lo[i] || o[i] > hi[i]) return std::nullopt;
      continue;
    }
    double a = (lo[i] - o[i]) / d[i], z = (hi[i] - o[i]) / d[i];
    if (a > z) std::swap(a, z);
    t0 = std::max(t0, a);
    t1 = std::min(t1, z);
    if (t0 > t1) return std::nullopt;
  }
  return t0;
}

/// The segment from `c` to `p` enters the box more than `tol` before it ends.
bool crosses(const PlacedBox& b, const Eigen::Vector3d& c, const Eigen::Vector3d& p, double tol) {
  const Eigen::Vector3d o = b.box_from_frame * c, d = b.box_from_frame * p - o;
  const auto t0 = entry(o, d, -b.half, b.half);
  return t0 && (1 - *t0) * d.norm() > tol;
}

struct Aabb {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  void add(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  /// The segment from c to p passes through it.
  bool crossed_by(const Eigen::Vector3d& c, const Eigen::Vector3d& p) const {
    return entry(c, p - c, lo, hi).has_value();
  }
};

std::vector<double> grid(double lo, double hi, double step) {
  std::vector<double> g;
  const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / step - 1e-9)));
  for (int i = 0; i <= n; ++i) g.push_back(lo + (hi - lo) * i / n);
  return g;
}

struct Count {
  std::size_t support = 0, through = 0;
  double score(double w) const { return static_cast<double>(support) - w * static_cast<double>(through); }
};

/// The volume box `b` of `model` sweeps over its range (placed at every value of `values`), grown by
/// `margin`.
Aabb swept_box(const PartModel& model, const BodyBox& b, const std::vector<double>& values, double margin) {
  Aabb swept;
  for (double q : values) {
    const Eigen::Isometry3d w = model.world_from_part(q);
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d corner(k & 1 ? b.half.x() : -b.half.x(), k & 2 ? b.half.y() : -b.half.y(),
                                   k & 4 ? b.half.z() : -b.half.z());
      swept.add(w * (b.centre + Eigen::AngleAxisd(b.yaw, Eigen::Vector3d::UnitZ()) * corner));
    }
  }
  swept.lo.array() -= margin;
  swept.hi.array() += margin;
  return swept;
}

/// The volume the whole part sweeps.
Aabb swept_box(const PartModel& model, const std::vector<double>& values, double margin) {
  Aabb swept;
  for (const auto& b : model.boxes) {
    const Aabb one = swept_box(model, b, values, margin);
    swept.add(one.lo);
    swept.add(one.hi);
  }
  return swept;
}

double step_of(const PartModel& model, const PartFitParams& params) {
  return model.joint == PartModel::Joint::Slide ? params.slide_step_m : params.hinge_step_rad;
}

}  // namespace

PartEstimate fit_part(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& camera,
                      const PartModel& model, const PartFitParams& params) {
  PartEstimate out;
  out.name = model.name;
  out.world_from_part = model.world_from_part(0);
  const auto place_riders = [&] {
    out.riders.clear();
    for (const auto& r : model.riders) out.riders.emplace_back(r.name, out.world_from_part * r.pos);
  };
  place_riders();
  if (model.boxes.empty() || !(model.hi > model.lo)) return out;
  const double step = step_of(model, params);
  const std::vector<double> coarse = grid(model.lo, model.hi, step);

  // Only rays through the volume the part sweeps can say anything about it, and a ray that misses the
  // volume one box sweeps is neither on that box nor through it at any value: each ray keeps the boxes it
  // can meet (an exact cut: the same fits in about half the time).
  std::vector<Aabb> box_swept;
  Aabb swept;
  for (const auto& b : model.boxes) {
    box_swept.push_back(swept_box(model, b, coarse, params.margin_m));
    swept.add(box_swept.back().lo);
    swept.add(box_swept.back().hi);
  }
  std::vector<PlacedBox> still;
  for (const auto& b : model.still) still.push_back(place(b, Eigen::Isometry3d::Identity()));
  struct Ray {
    Eigen::Vector3d p;
    bool explained;  ///< on or in the fixture's body or the table: supports no joint value
    std::vector<unsigned> boxes;  ///< the boxes whose swept volume it crosses
  };
  std::vector<Ray> rays;
  for (const auto& p : points) {
    if (!swept.crossed_by(camera, p)) continue;
    Ray r{p, false, {}};
    for (std::size_t i = 0; i < box_swept.size(); ++i)
      if (box_swept[i].crossed_by(camera, p)) r.boxes.push_back(static_cast<unsigned>(i));
    if (r.boxes.empty()) continue;
    r.explained = std::any_of(still.begin(), still.end(), [&](const PlacedBox& b) {
      return where(b, p, params.surface_m) != Where::Away;
    });
    rays.push_back(std::move(r));
  }

  const auto count = [&](double q) {
    std::vector<PlacedBox> boxes;
    for (const auto& b : model.boxes) boxes.push_back(place(b, model.world_from_part(q)));
    Count c;
    for (const auto& r : rays) {
      bool on = false, deep = false;
      for (const unsigned i : r.boxes) {
        const Where w = where(boxes[i], r.p, params.surface_m);
        on |= w == Where::Surface;
        deep |= w == Where::Deep;
      }
      if (on && !deep) {
        if (!r.explained) ++c.support;
      } else if (deep || std::any_of(r.boxes.begin(), r.boxes.end(), [&](unsigned i) {
                   return crosses(boxes[i], camera, r.p, params.surface_m);
                 })) {
        ++c.through;
      }
    }
    return c;
  };

  // Every value's count, and the first of the best.
  const auto score_all = [&](const std::vector<double>& values, std::vector<Count>& c) {
    std::size_t first_best = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
      c.push_back(count(values[i]));
      if (c[i].score(params.through_weight) > c[first_best].score(params.through_weight)) first_best = i;
    }
    return first_best;
  };
  std::vector<Count> counts;
  const std::size_t best = score_all(coarse, counts);
  const double best_score = counts[best].score(params.through_weight);
  double spread_lo = coarse[best], spread_hi = coarse[best];
  if (best_score > 0)
    for (std::size_t i = 0; i < coarse.size(); ++i)
      if (counts[i].score(params.through_weight) >= params.near_best * best_score) {
        spread_lo = std::min(spread_lo, coarse[i]);
        spread_hi = std::max(spread_hi, coarse[i]);
      }
  // Depth cannot tell apart values whose placements differ by less than its tolerance: of a run of equal
  // best scores, the middle is taken (the first would bias every fit towards the range's low end).
  const auto middle_of_run = [&](const std::vector<double>& values, const std::vector<Count>& c, std::size_t first) {
    const double top = c[first].score(params.through_weight);
    std::size_t last = first;
    while (last + 1 < values.size() && c[last + 1].score(params.through_weight) == top) ++last;
    return (values[first] + values[last]) / 2;
  };
  const double q_coarse = middle_of_run(coarse, counts, best);
  std::vector<double> fine;
  for (double q = std::max(model.lo, q_coarse - step); q <= std::min(model.hi, q_coarse + step) + 1e-12; q += step / 4)
    fine.push_back(q);
  std::vector<Count> fine_counts;
  const double q_best = middle_of_run(fine, fine_counts, score_all(fine, fine_counts));
  const Count c_best = count(q_best);
  out.joint = q_best;
  out.support = c_best.support;
  out.through = c_best.through;
  out.spread = spread_hi - spread_lo;
  out.world_from_part = model.world_from_part(q_best);
  place_riders();
  if (out.support >= params.min_support) {
    const double clean = static_cast<double>(out.support) / static_cast<double>(out.support + out.through);
    const double sharp = std::max(0.0, 1.0 - out.spread / (0.25 * (model.hi - model.lo)));
    out.confidence = clean * sharp;
  }
  return out;
}

std::vector<PartEstimate> fit_parts(const RgbdFrame& frame, const std::vector<PartModel>& models,
                                    const PartFitParams& params, const CloudParams& cloud) {
  validate(frame);
  std::vector<PartEstimate> out;
  const Eigen::Isometry3d camera_from_world = frame.world_from_camera.inverse();
  const Eigen::Vector3d camera = frame.world_from_camera.translation();
  const double min_mm = cloud.min_depth_m * 1000.0, max_mm = cloud.max_depth_m * 1000.0;
  for (const auto& m : models) {
    // The pixels whose rays can cross the part's swept volume: its corners' image, back-projected at a
    // stride that keeps about max_points of them.
    const Aabb swept = swept_box(m, grid(m.lo, m.hi, step_of(m, params)), params.margin_m);
    double u0 = frame.K.width, u1 = -1, v0 = frame.K.height, v1 = -1;
    bool behind = false;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d c = camera_from_world * Eigen::Vector3d(k & 1 ? swept.hi.x() : swept.lo.x(),
                                                                    k & 2 ? swept.hi.y() : swept.lo.y(),
                                                                    k & 4 ? swept.hi.z() : swept.lo.z());
      if (c.z() <= 1e-6) {
        behind = true;
        break;
      }
      const double u = frame.K.fx * c.x() / c.z() + frame.K.cx, v = frame.K.fy * c.y() / c.z() + frame.K.cy;
      u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
    int ua = 0, ub = frame.K.width - 1, va = 0, vb = frame.K.height - 1;
    if (!behind) {
      ua = std::max(0, static_cast<int>(std::floor(u0))), ub = std::min(frame.K.width - 1, static_cast<int>(std::ceil(u1)));
      va = std::max(0, static_cast<int>(std::floor(v0))), vb = std::min(frame.K.height - 1, static_cast<int>(std::ceil(v1)));
    }
    std::vector<Eigen::Vector3d> points;
    if (ua <= ub && va <= vb) {
      const double area = static_cast<double>(ub - ua + 1) * (vb - va + 1);
      const int stride = std::max(1, static_cast<int>(std::floor(std::sqrt(area / static_cast<double>(params.max_points)))));
      for (int v = va; v <= vb; v += stride) {
        const auto* row = frame.depth.ptr<std::uint16_t>(v);
        for (int u = ua; u <= ub; u += stride) {
          const double mm = row[u];
          if (mm < min_mm || mm > max_mm) continue;
          const double z = mm / 1000.0;
          points.push_back(frame.world_from_camera *
                           Eigen::Vector3d((u - frame.K.cx) * z / frame.K.fx, (v - frame.K.cy) * z / frame.K.fy, z));
        }
      }
    }
    out.push_back(fit_part(points, camera, m, params));
  }
  return out;
}

}  // namespace dh::perception
