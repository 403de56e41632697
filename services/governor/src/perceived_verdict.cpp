#include "dh/gov/perceived_verdict.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace dh::gov {

namespace {

// v in the frame of unit quaternion q (w, x, y, z): q* v q.
std::array<double, 3> into_frame(const std::array<double, 4>& q, const std::array<double, 3>& v) {
  const double w = q[0], x = -q[1], y = -q[2], z = -q[3];  // the conjugate rotates world into the frame
  const double tx = 2 * (y * v[2] - z * v[1]), ty = 2 * (z * v[0] - x * v[2]), tz = 2 * (x * v[1] - y * v[0]);
  return {v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz), v[2] + w * tz + (x * ty - y * tx)};
}

bool rests_on(double bottom, double surface) {
  return bottom > surface - kPerceivedRestBelow && bottom < surface + kPerceivedRestAbove;
}

bool holds_spatial(const GoalTerm& t, const Observation& seen) {
  const EntityState* a = seen.entity(t.args.at(0));
  const EntityState* b = seen.entity(t.args.at(1));
  if (!a || !b || seen.in_jaw(*a)) return false;
  if (b->kind != "region") {
    if (t.predicate != "On") return false;
    // On another object: over it and resting on it or in it (a bowl's floor is below its rim).
    return std::hypot(a->p[0] - b->p[0], a->p[1] - b->p[1]) < kPerceivedOnXy &&
           a->p[2] > b->p[2] - kPerceivedRestBelow && a->p[2] < b->p[2] + 2 * b->half_extents[2] + kPerceivedRestAbove;
  }
  const auto local = into_frame(b->q, {a->p[0] - b->p[0], a->p[1] - b->p[1], a->p[2] - b->p[2]});
  const auto& h = b->half_extents;
  if (std::abs(local[0]) >= h[0] || std::abs(local[1]) >= h[1]) return false;
  if (t.predicate == "In") return local[2] > -h[2] - kPerceivedInFloor && local[2] < h[2];
  if (rests_on(local[2], h[2])) return true;  // the region's top face is the surface
  // Or what it rests on is its fixture's top above that face (a wine rack's rails over its cradle's
  // floor): the region says where, the fixture's box how high.
  const EntityState* owner = b->relation == "on" ? seen.entity(b->owner) : nullptr;
  const bool is_part = owner && !owner->owner.empty();  // a part's place is its grip, not its box
  return owner && !is_part && rests_on(a->p[2], owner->p[2] + 2 * owner->half_extents[2]);
}

}  // namespace

bool term_holds(const GoalTerm& term, const Observation& seen) {
  if (term.articulated()) {
    const EntityState* part = seen.entity(term.part);
    return part && part->joint >= term.lo && part->joint <= term.hi;
  }
  if (term.args.size() != 2) return false;
  return holds_spatial(term, seen);
}

std::vector<TermCheck> check_terms(const std::vector<GoalTerm>& goal, const Observation& seen, const Observation& truth) {
  std::vector<TermCheck> checks;
  for (const GoalTerm& t : goal) {
    TermCheck c;
    c.term = t.text();
    c.subject = t.articulated() ? t.part : t.args.empty() ? "" : t.args[0];
    c.perceived = term_holds(t, seen);
    c.seen = seen.entity(c.subject);
    c.truth = truth.entity(c.subject);
    if (!t.articulated() && t.args.size() == 2) {
      c.support_seen = seen.entity(t.args[1]);
      c.support_truth = truth.entity(t.args[1]);
      if (c.support_seen && c.support_seen->kind == "region") c.support_seen = c.support_truth = nullptr;
    }
    if (c.truth) c.on_true_poses = term_holds(t, truth);
    checks.push_back(std::move(c));
  }
  return checks;
}

PerceivedVerdict::PerceivedVerdict(std::vector<GoalTerm> goal, std::uint32_t frames)
    : goal_(std::move(goal)), frames_(frames) {
  if (frames_ == 0) throw std::invalid_argument("a perceived verdict needs at least one frame in agreement");
}

std::optional<PerceivedVerdict::Change> PerceivedVerdict::on_frame(std::uint32_t step, const Observation& seen) {
  if (last_step_ && step < *last_step_) return std::nullopt;
  last_step_ = step;
  const bool now = !goal_.empty() && std::all_of(goal_.begin(), goal_.end(), [&](const GoalTerm& t) { return term_holds(t, seen); });
  if (now == value_) {
    run_ = 0;
    return std::nullopt;
  }
  if (++run_ < frames_) return std::nullopt;
  value_ = now;
  run_ = 0;
  return Change{step, now};
}

}  // namespace dh::gov
