#include "dh/cap/pick_place.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dh/common/geometry.hpp"

namespace dh::cap {

namespace {

/// An approach that ends farther than this from its target was stopped short (m); the 49 approaches of
/// the physics tests end within 9 mm.
constexpr double kApproachMissM = 0.03;

/// Room a held box keeps from each side of a region it is turned to fit (m).
constexpr double kFitMarginM = 0.005;

bool inside_xy(const EntityState& e, const Eigen::Vector2d& xy, double margin) {
  return std::abs(xy.x() - e.p[0]) < e.half_extents[0] + margin && std::abs(xy.y() - e.p[1]) < e.half_extents[1] + margin;
}

/// A body the jaw holds alike across any diameter (a bottle, a pot): its footprint is square.
bool round_body(const EntityState& e) { return std::abs(e.half_extents[0] - e.half_extents[1]) < 1e-3; }

/// The turn about the vertical (rad, at most a quarter turn) that lines the box `o` up with the region
/// `t` when its footprint does not fit the region at its present yaw but does lined up (a book and a
/// caddy's compartment); 0 when it fits as it is, or in no way.
double fitting_turn(const EntityState& o, const EntityState& t) {
  if (t.kind != "region") return 0;
  const double a = o.half_extents[0], b = o.half_extents[1];
  const auto fits = [&](double yaw) {
    const double c = std::abs(std::cos(yaw)), s = std::abs(std::sin(yaw));
    return a * c + b * s <= t.half_extents[0] - kFitMarginM &&
           a * s + b * c <= t.half_extents[1] - kFitMarginM;
  };
  const double yaw = geo::wrap(geo::tool_yaw(geo::quat(o.q)) - geo::tool_yaw(geo::quat(t.q)));
  if (fits(yaw)) return 0;
  std::optional<double> best;
  for (int k = -2; k <= 2; ++k) {
    const double turn = geo::wrap(k * std::numbers::pi / 2 - yaw);
    if (std::abs(turn) <= std::numbers::pi / 2 + 1e-9 && fits(yaw + turn) &&
        (!best || std::abs(turn) < std::abs(*best)))
      best = turn;
  }
  return best.value_or(0);
}

/// The drawer whose inside `target` is, or null: a region owned by a part of kind drawer.
const EntityState* drawer_holding(const Observation& obs, const std::string& target) {
  const EntityState* t = obs.entity(target);
  if (!t || t->kind != "region" || t->owner.empty()) return nullptr;
  const EntityState* d = obs.entity(t->owner);
  return d && d->kind == "drawer" ? d : nullptr;
}
}  // namespace

std::optional<Cavity> find_cavity(const Observation& obs, const std::string& target, const std::string& object) {
  const EntityState* t = obs.entity(target);
  if (!t || t->kind != "region") return std::nullopt;
  for (const auto& c : obs.entities) {
    if (part_or_region(c) || c.name == object) continue;
    if (!inside_xy(c, {t->p[0], t->p[1]}, 0) || top_of(c) <= top_of(*t) + 0.005 || c.p[2] > t->p[2]) continue;
    // Closed over the top: a fixture with a door (a microwave), not an open container (a caddy, a basket).
    const bool has_door = std::any_of(obs.entities.begin(), obs.entities.end(), [&](const EntityState& d) {
      return d.kind == "door" && d.name.rfind(c.name + "_", 0) == 0;
    });
    if (!has_door) continue;
    Cavity k;
    k.fixture = c.name;
    k.out = front_of(c);
    k.floor = t->p[2] - t->half_extents[2];
    k.ceiling = top_of(c);
    // From the region's centre to the fixture's front face, along the way out.
    k.depth = (Eigen::Vector2d(c.p[0], c.p[1]) - Eigen::Vector2d(t->p[0], t->p[1])).dot(k.out) + c.half_extents[0];
    return k;
  }
  return std::nullopt;
}

bool has_rim(const EntityState& e) {
  return e.kind == "bowl" || e.kind == "plate" || e.kind == "mug" || e.kind == "cup" || e.kind == "ring";
}

double PickPlaceSkill::grasp_above_bottom(const EntityState& o, const robot::Gripper& g) const {
  if (has_rim(o))
    return 2 * o.half_extents[2] - std::min(p_.rim_grasp_depth, 2 * o.half_extents[2] - g.pad_below_tcp - 0.011);
  return std::max(o.half_extents[2], 2 * o.half_extents[2] - 0.03);
}

double rim_radius(const EntityState& e) {
  // A mug's x extent includes its handle; its rim is the y extent. Walls are 6-8 mm thick.
  return std::min(e.half_extents[0], e.half_extents[1]) - 0.0035;
}

ParamTable PickPlaceParams::table(bool grasp_only) {
  // The recovery skills regrasp and reseat approach, descend and close only: these are all they read.
  if (grasp_only)
    return ParamTable("pick_place (grasp only: regrasp, reseat)",
                      {{"approach_height", &approach_height}, {"corridor_clearance", &corridor_clearance},
                       {"rim_grasp_depth", &rim_grasp_depth}, {"lean_angle", &lean_angle},
                       {"lean_within", &lean_within}, {"approach_steps", &approach_steps},
                       {"descent_steps", &descent_steps}, {"close_steps", &close_steps}});
  return ParamTable("pick_place", {{"approach_height", &approach_height}, {"corridor_height", &corridor_height},
                                   {"corridor_clearance", &corridor_clearance}, {"rim_grasp_depth", &rim_grasp_depth},
                                   {"place_clearance", &place_clearance}, {"max_speed", &max_speed},
                                   {"cavity_clearance", &cavity_clearance}, {"cavity_ceiling", &cavity_ceiling},
                                   {"lean_angle", &lean_angle}, {"lean_within", &lean_within},
                                   {"retreat_height", &retreat_height}, {"approach_steps", &approach_steps},
                                   {"descent_steps", &descent_steps}, {"close_steps", &close_steps},
                                   {"lift_steps", &lift_steps}, {"carry_min_steps", &carry_min_steps},
                                   {"carry_max_steps", &carry_max_steps}, {"lower_steps", &lower_steps},
                                   {"release_steps", &release_steps}, {"retreat_steps", &retreat_steps}});
}

PickPlaceSkill::PickPlaceSkill(const Theta& theta, bool grasp_only) : grasp_only_(grasp_only) {
  p_.table(grasp_only).load(theta);
}

int PickPlaceSkill::cost_steps() const {
  if (grasp_only_) return steps(p_.approach_steps + p_.descent_steps + p_.close_steps);
  return steps(p_.approach_steps + p_.descent_steps + p_.close_steps + p_.lift_steps + p_.carry_max_steps +
               p_.lower_steps + p_.release_steps + p_.retreat_steps);
}


std::optional<std::string> PickPlaceSkill::check(const Bindings& args, const Observation& obs, int budget_steps) const {
  const std::string object = arg(args, "object"), target = arg(args, "target");
  const EntityState* o = obs.entity(object);
  if (!o) return "object '" + object + "' is not in the scene";
  if (grasp_only_) {
    if (obs.in_jaw(*o)) return "'" + object + "' is in the jaw already";
    if (budget_steps < cost_steps())
      return "budget of " + std::to_string(budget_steps) + " steps cannot pay for a grasp of " + std::to_string(cost_steps());
    return std::nullopt;
  }
  const EntityState* t = obs.entity(target);
  if (!t) return "target '" + target + "' is not in the scene";
  if (object == target) return "object and target are the same entity '" + object + "'";
  if (part_or_region(*o))
    return "'" + object + "' is a " + o->kind + ", not an object a jaw can carry";
  if (!has_rim(*o) && 2 * std::min(o->half_extents[0], o->half_extents[1]) > robot::kJawMaxGapM - 0.002)
    return "object '" + object + "' is wider than the jaw opens";
  if (const auto cav = find_cavity(obs, target, object)) {
    // Into a cavity the hand goes in level under its ceiling: it must fit above the object's grasp.
    const double tcp = cav->floor + p_.cavity_clearance + grasp_above_bottom(*o, obs.gripper);
    if (tcp + obs.gripper.hand_above_tcp > cav->ceiling - p_.cavity_ceiling)
      return "the hand does not fit into '" + cav->fixture + "' holding '" + object + "': it would reach " +
             std::to_string(tcp + obs.gripper.hand_above_tcp) + " m under a ceiling at " +
             std::to_string(cav->ceiling - p_.cavity_ceiling) + " m";
    // Going in level and backing out again: a longer lower, the insert and the withdrawal.
    if (budget_steps < cost_steps() + steps(5 * p_.lower_steps))
      return "budget of " + std::to_string(budget_steps) + " steps cannot pay for placing into '" + cav->fixture +
             "' (" + std::to_string(cost_steps() + steps(5 * p_.lower_steps)) + " steps)";
  }
  if (budget_steps < cost_steps())
    return "budget of " + std::to_string(budget_steps) + " steps cannot pay for pick_place's cost of " +
           std::to_string(cost_steps()) + " steps";
  return std::nullopt;
}

void PickPlaceSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  object_ = arg(args, "object");
  target_ = arg(args, "target");
  cavity_ = grasp_only_ ? std::nullopt : find_cavity(obs, target_, object_);
  total_steps_ = 0;
  committed_ = 0;
  plan_steps_after();
  turned_back_ = false;
  const EntityState& o = *obs.entity(object_);
  const Eigen::Vector3d c = geo::vec(o.p);
  const Eigen::Vector3d ee = geo::vec(obs.ee_p);
  const double ee_yaw = geo::tool_yaw(geo::quat(obs.ee_q));
  const Eigen::Vector2d from_base(c.x() - obs.base_p[0], c.y() - obs.base_p[1]);
  double yaw;
  if (has_rim(o)) {
    // Pinch the rim at the point nearest the tool; the jaw closes across the wall (radially). A mug's
    // handle (+x of its body) is avoided by at least 60°.
    double phi = std::atan2(ee.y() - c.y(), ee.x() - c.x());
    // Into a cavity the hand follows the object in: take it on the side that faces out. Into a drawer pulled
    // out of its cabinet the hand comes down over the part left open, under the handles of the drawers
    // above: taken on the drawer's front side, the hand's 20 cm span along the radius runs along the pull
    // and its narrow side fits between those handles.
    if (cavity_) {
      phi = std::atan2(cavity_->out.y(), cavity_->out.x());
    } else if (const EntityState* d = grasp_only_ ? nullptr : drawer_holding(obs, target_)) {
      const Eigen::Vector2d front = front_of(*d);
      phi = std::atan2(front.y(), front.x());
    }
    if (o.kind == "mug") {
      const double handle = geo::tool_yaw(geo::quat(o.q));
      const double d = geo::wrap(phi - handle);
      if (std::abs(d) < std::numbers::pi / 3) phi = handle + (d >= 0 ? 1 : -1) * std::numbers::pi / 3;
    }
    const double r = rim_radius(o);
    grasp_ = {c.x() + r * std::cos(phi), c.y() + r * std::sin(phi), o.p[2] + grasp_above_bottom(o, obs.gripper)};
    yaw = phi + std::numbers::pi / 2;
  } else {
    // Close across the narrow side of a box, at half its height (a cylinder: any side).
    const double obj_yaw = geo::tool_yaw(geo::quat(o.q));
    const bool narrow_x = o.half_extents[0] <= o.half_extents[1];
    yaw = narrow_x ? obj_yaw + std::numbers::pi / 2 : obj_yaw;
    // A round body (a bottle) is held across any diameter: keep the wrist where it is, or near the base
    // close across the way to it, so that the whole lean goes towards the base.
    if (round_body(o)) yaw = leans(from_base) ? std::atan2(from_base.y(), from_base.x()) : ee_yaw;
    grasp_ = {c.x(), c.y(), o.p[2] + grasp_above_bottom(o, obs.gripper)};
  }
  // The jaw is symmetric: of yaw and yaw+π take the one closer to the tool's current yaw.
  if (std::abs(geo::wrap(yaw - ee_yaw)) > std::numbers::pi / 2) yaw += std::numbers::pi;
  grasp_q_ = geo::top_down(geo::wrap(yaw));
  if (!has_rim(o)) grasp_q_ = lean(grasp_q_, from_base);  // a rim's pinch stays vertical
  // Already in the jaw (a regrasp just took it): go on from the lift.
  enter(!grasp_only_ && obs.in_jaw(o) ? Stage::Lift : Stage::Approach, obs);
}

bool PickPlaceSkill::leans(const Eigen::Vector2d& from_base) const {
  return p_.lean_angle > 0 && from_base.norm() < p_.lean_within;
}

Eigen::Quaterniond PickPlaceSkill::lean(const Eigen::Quaterniond& q, const Eigen::Vector2d& from_base) const {
  // Near its base a vertical hand cannot come down: the wrist would have to fold in over the base. Turned
  // about the jaw's closing axis (tool y), the tool axis leans towards the base and the wrist moves away
  // from it by its distance from the tool centre times sin(lean_angle); the pads' planes stay as they were.
  if (!leans(from_base)) return q;
  const Eigen::Vector3d closing = q * Eigen::Vector3d::UnitY();
  const Eigen::Quaterniond leant = Eigen::Quaterniond(Eigen::AngleAxisd(p_.lean_angle, closing)) * q;
  // Of the two turns, the one whose tool axis points towards the base.
  if ((leant * Eigen::Vector3d::UnitZ()).head<2>().dot(from_base) <= 0) return leant;
  return Eigen::Quaterniond(Eigen::AngleAxisd(-p_.lean_angle, closing)) * q;
}

const char* PickPlaceSkill::stage_name(Stage s) {
  switch (s) {
    case Stage::Approach: return "approach";
    case Stage::Descent: return "guarded_descent";
    case Stage::Close: return "close";
    case Stage::Lift: return "lift";
    case Stage::Carry: return "carry";
    case Stage::Lower: return "lower";
    case Stage::Insert: return "insert";
    case Stage::Withdraw: return "withdraw";
    case Stage::Release: return "release";
    case Stage::Retreat: return "retreat";
    case Stage::Done: return "done";
  }
  return "?";
}

Eigen::Vector2d PickPlaceSkill::place_xy(const Observation& obs) const {
  const EntityState& t = *obs.entity(target_);
  const EntityState& o = *obs.entity(object_);
  const Eigen::Vector2d centre(t.p[0], t.p[1]);
  // A body's room on the table: a rim's radius, a handled pot's body, else the box's larger half side.
  const auto room = [](const EntityState& e) {
    return has_rim(e) || e.kind == "moka_pot" ? std::min(e.half_extents[0], e.half_extents[1])
                                              : std::max(e.half_extents[0], e.half_extents[1]);
  };
  const double r = room(o);
  const double fx = std::max(0.0, t.half_extents[0] - r - 0.005), fy = std::max(0.0, t.half_extents[1] - r - 0.005);
  auto handle = [](const EntityState& e) { return e.kind == "drawer" || e.kind == "door"; };
  // What fits through a ring's hole (the post it goes over) is not in its way: it passes inside.
  const double hole = o.kind == "ring" ? rim_radius(o) - 0.006 : 0;
  auto through_hole = [&](const EntityState& e) { return std::max(e.half_extents[0], e.half_extents[1]) < hole; };
  // Objects already resting in or on the target take their room; the slots are the centre and the
  // eight points half a free width away from it.
  std::vector<const EntityState*> occupants;
  for (const auto& e : obs.entities)
    if (e.name != object_ && e.name != target_ && !part_or_region(e) && e.half_extents[0] < t.half_extents[0] &&
        inside_xy(t, {e.p[0], e.p[1]}, 0) && e.p[2] >= t.p[2] - t.half_extents[2] - 0.01)
      occupants.push_back(&e);
  const auto at = [](const EntityState* q) { return Eigen::Vector2d(q->p[0], q->p[1]); };
  // How far a slot's body stays from the nearest occupant's (negative: they overlap).
  const auto clearance = [&](const Eigen::Vector2d& c) {
    double gap = 1e9;
    for (const auto* q : occupants) gap = std::min(gap, (c - at(q)).norm() - room(*q) - r);
    return gap;
  };
  Eigen::Vector2d best = centre;
  double best_gap = -1;
  if (!occupants.empty())
    for (int i = -1; i <= 1; ++i)
      for (int j = -1; j <= 1; ++j) {
        const Eigen::Vector2d c = centre + Eigen::Vector2d(i * fx, j * fy);
        double gap = 1e9;
        for (const auto* q : occupants) gap = std::min(gap, (c - at(q)).norm());
        if (gap > best_gap + 1e-6) {
          best_gap = gap;
          best = c;
        }
      }
  // On a surface (a thin region: a burner) too small for both bodies inside it, the object may overhang
  // its edge with its centre 1 cm inside (the On predicate reads the centre), when no inner slot is clear.
  if (!occupants.empty() && t.kind == "region" && t.half_extents[2] <= 0.02 && clearance(best) < 0) {
    const double ex = std::max(0.0, t.half_extents[0] - 0.01), ey = std::max(0.0, t.half_extents[1] - 0.01);
    for (int i = -1; i <= 1; ++i)
      for (int j = -1; j <= 1; ++j) {
        const Eigen::Vector2d c = centre + Eigen::Vector2d(i * ex, j * ey);
        if (clearance(c) > clearance(best) + 1e-6) best = c;
      }
  }
  if (t.kind != "region") return best;
  // A region partly under something taller (a drawer pulled out of its cabinet): the object comes down
  // where nothing stands over it, as far as the region allows. Fixtures and the handles of other drawers
  // count; regions, knobs and what rests inside do not.
  std::vector<const EntityState*> covers;
  for (const auto& c : obs.entities) {
    const bool rests_inside = inside_xy(t, {c.p[0], c.p[1]}, 0) && c.p[2] <= top_of(t);
    if ((part_or_region(c) && !handle(c)) || c.name == object_ || top_of(c) <= top_of(t) + 0.01 ||
        rests_inside || through_hole(c))
      continue;
    covers.push_back(&c);
  }
  // How far the object's body at `c` reaches under `k` along x and y (either one ≤ 0: not under it).
  const auto under = [&](const Eigen::Vector2d& c, const EntityState& k) {
    return Eigen::Vector2d(k.half_extents[0] + r + 0.005 - std::abs(c.x() - k.p[0]),
                           k.half_extents[1] + r + 0.005 - std::abs(c.y() - k.p[1]));
  };
  for (const auto* k : covers) {
    const Eigen::Vector2d o = under(best, *k);
    if (o.x() <= 0 || o.y() <= 0) continue;
    if (o.x() < o.y())
      best.x() += best.x() < k->p[0] ? -o.x() : o.x();
    else
      best.y() += best.y() < k->p[1] ? -o.y() : o.y();
    best.x() = std::clamp(best.x(), centre.x() - fx, centre.x() + fx);
    best.y() = std::clamp(best.y(), centre.y() - fy, centre.y() + fy);
  }
  // In a drawer the hand comes down between the handles of the drawers above, which hang over the strip
  // left open, high above the object but in the hand's way: of the places whose body is clear of the
  // other covers (the cabinet), the one farthest from those handles.
  std::vector<const EntityState*> handles;
  for (const auto* k : covers)
    if (handle(*k)) handles.push_back(k);
  if (handles.empty() || !drawer_holding(obs, target_)) return best;
  const auto distance = [&](const Eigen::Vector2d& c) {
    double d = 1e9;
    for (const auto* k : handles)
      d = std::min(d, std::hypot(std::max(0.0, std::abs(c.x() - k->p[0]) - k->half_extents[0]),
                                 std::max(0.0, std::abs(c.y() - k->p[1]) - k->half_extents[1])));
    return d;
  };
  double best_distance = -1;
  Eigen::Vector2d farthest = best;
  constexpr int kGrid = 8;  // (2 kGrid + 1)² places over the free rectangle
  for (int i = -kGrid; i <= kGrid; ++i)
    for (int j = -kGrid; j <= kGrid; ++j) {
      const Eigen::Vector2d c = centre + Eigen::Vector2d(fx * i / kGrid, fy * j / kGrid);
      const bool clear = std::all_of(covers.begin(), covers.end(), [&](const EntityState* k) {
        const Eigen::Vector2d o = under(c, *k);
        return handle(*k) || o.x() <= 0 || o.y() <= 0;
      });
      if (!clear) continue;
      if (const double d = distance(c); d > best_distance + 1e-9) {
        best_distance = d;
        farthest = c;
      }
    }
  return farthest;
}

double PickPlaceSkill::corridor_z(const Observation& obs, const Eigen::Vector2d& to) const {
  // The carried object's bottom passes above the target and everything between here and there.
  const Eigen::Vector2d from(obs.ee_p[0], obs.ee_p[1]);
  const double floor = std::max(p_.corridor_height, top_of(*obs.entity(target_)) + p_.corridor_clearance);
  return path_height(obs, from, to, 0.05, p_.corridor_clearance, floor, {object_, target_});
}

void PickPlaceSkill::enter(Stage s, const Observation& obs) {
  stage_ = s;
  const Eigen::Vector3d ee = geo::vec(obs.ee_p);
  const Eigen::Quaterniond eq = geo::quat(obs.ee_q);
  switch (s) {
    case Stage::Approach: {
      // Above the grasp, high enough that the hand passes over what stands between (an open drawer).
      const Eigen::Vector2d to(grasp_.x(), grasp_.y());
      const double z = path_height(obs, {ee.x(), ee.y()}, to, 0.08, p_.corridor_clearance,
                                   grasp_.z() + p_.approach_height, {object_});
      m_.go(obs, {to.x(), to.y(), z}, grasp_q_,
            steps(p_.approach_steps * std::max(1.0, (z - grasp_.z()) / p_.approach_height / 2)));
      break;
    }
    case Stage::Descent:
      m_.go(obs, grasp_, grasp_q_, steps(p_.descent_steps * std::max(1.0, (ee.z() - grasp_.z()) / p_.approach_height)));
      break;
    case Stage::Close:
      m_.hold(obs, steps(p_.close_steps));
      break;
    case Stage::Release:
      m_.hold(obs, steps(p_.release_steps));
      break;
    case Stage::Lift: {
      const EntityState& o = *obs.entity(object_);
      object_z0_ = o.p[2];
      grasp_offset_ = {ee.x() - o.p[0], ee.y() - o.p[1]};
      grasp_height_ = ee.z() - o.p[2];
      place_ = place_xy(obs);
      // A rim or a round body fits any way round; a box may need turning on the way (in the carry).
      place_turn_ = has_rim(o) || cavity_ || round_body(o) ? 0 : fitting_turn(o, *obs.entity(target_));
      cavity_radius_ = std::max(o.half_extents[0], o.half_extents[1]);
      const double z =
          corridor_z(obs, (cavity_ ? entry_xy() : place_) + Eigen::Rotation2Dd(place_turn_) * grasp_offset_);
      m_.go(obs, {ee.x(), ee.y(), z + grasp_height_}, grasp_q_, steps(p_.lift_steps * std::max(1.0, z / p_.corridor_height)));
      break;
    }
    case Stage::Carry: {
      // The held object turns with the hand about the vertical through the tool centre, and so does its
      // offset from the tool.
      grasp_q_ = Eigen::AngleAxisd(place_turn_, Eigen::Vector3d::UnitZ()) * grasp_q_;
      grasp_offset_ = Eigen::Rotation2Dd(place_turn_) * grasp_offset_;
      // Into a cavity: to the point in front of its opening the object will slide in from.
      const Eigen::Vector2d over = cavity_ ? entry_xy() : place_;
      const Eigen::Vector3d to(over.x() + grasp_offset_.x(), over.y() + grasp_offset_.y(), ee.z());
      const double dist = (to - ee).norm();
      m_.go(obs, to, grasp_q_,
            std::clamp(static_cast<int>(std::ceil(dist / (p_.max_speed * robot::kControlPeriodS) * 1.9)), steps(p_.carry_min_steps),
                       steps(p_.carry_max_steps)));
      break;
    }
    case Stage::Lower: {
      if (cavity_) {
        const Eigen::Vector2d e = entry_xy();
        m_.go(obs, {e.x() + grasp_offset_.x(), e.y() + grasp_offset_.y(), cavity_->floor + p_.cavity_clearance + grasp_height_},
              grasp_q_, steps(p_.lower_steps * 2));
        break;
      }
      const EntityState& t = *obs.entity(target_);
      // A deep region (a basket's or drawer's inside) is filled from its floor; a thin one is a surface.
      const double surface = t.kind == "region" && t.half_extents[2] > 0.02 ? t.p[2] - t.half_extents[2] : top_of(t);
      m_.go(obs, {place_.x() + grasp_offset_.x(), place_.y() + grasp_offset_.y(), surface + p_.place_clearance + grasp_height_},
            grasp_q_, steps(p_.lower_steps));
      break;
    }
    case Stage::Insert:
      m_.go(obs, {place_.x() + grasp_offset_.x(), place_.y() + grasp_offset_.y(), ee.z()}, grasp_q_,
            steps(p_.lower_steps * 2));
      break;
    case Stage::Withdraw: {
      const Eigen::Vector2d e = entry_xy();
      m_.go(obs, {e.x() + grasp_offset_.x(), e.y() + grasp_offset_.y(), ee.z()}, eq, steps(p_.lower_steps * 2));
      break;
    }
    case Stage::Retreat:
      m_.go(obs, ee + Eigen::Vector3d(0, 0, p_.retreat_height), eq, steps(p_.retreat_steps));
      break;
    case Stage::Done:
      return;
  }
  committed_ += m_.steps();
}

void PickPlaceSkill::plan_steps_after() {
  // θ's steps of each stage, in the order this command runs them (a cavity's are slower: enter()).
  const int into = steps(p_.lower_steps * (cavity_ ? 2 : 1));
  std::vector<std::pair<Stage, int>> plan{{Stage::Approach, steps(p_.approach_steps)},
                                          {Stage::Descent, steps(p_.descent_steps)},
                                          {Stage::Close, steps(p_.close_steps)}};
  if (!grasp_only_) {
    plan.insert(plan.end(), {{Stage::Lift, steps(p_.lift_steps)},
                             {Stage::Carry, steps(p_.carry_max_steps)},
                             {Stage::Lower, into}});
    if (cavity_) plan.emplace_back(Stage::Insert, into);
    plan.emplace_back(Stage::Release, steps(p_.release_steps));
    if (cavity_) plan.emplace_back(Stage::Withdraw, into);
    plan.emplace_back(Stage::Retreat, steps(p_.retreat_steps));
  }
  steps_after_.fill(0);  // Done, and stages this plan skips
  int after = 0;
  for (auto it = plan.rbegin(); it != plan.rend(); ++it) {
    steps_after_[static_cast<int>(it->first)] = after;
    after += it->second;
  }
}

Eigen::Vector2d PickPlaceSkill::entry_xy() const {
  return place_ + cavity_->out * (cavity_->depth + cavity_radius_ + 0.03);
}

SkillStep PickPlaceSkill::next(const Observation& obs) {
  SkillStep out;
  out.stage = stage_name(stage_);
  const EntityState* o = obs.entity(object_);
  if (!o || (!grasp_only_ && !obs.entity(target_)))
    return failed(out, FailureCode::EntityLost, "entity '" + (o ? target_ : object_) + "' left the observation");
  auto fail = [&](FailureCode code, const std::string& why) { return failed(out, code, why); };
  // Stage transitions driven by what is observed.
  switch (stage_) {
    case Stage::Approach:
      if (!m_.done()) break;
      // A wrist joint at its limit stops the hand short (after a knob turned to its end, say). The jaw is
      // symmetric: the grasp turned by π asks the wrist for the other way round, once.
      if (!turned_back_ && m_.error(obs) > kApproachMissM) {
        turned_back_ = true;
        grasp_q_ =
            grasp_q_ * Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitZ()));
        enter(Stage::Approach, obs);
        break;
      }
      enter(Stage::Descent, obs);
      break;
    case Stage::Descent:
      // Guarded: stop early when a finger touches something or the target is reached.
      if (m_.done() || m_.error(obs) < 0.003 || (m_.elapsed() > 3 && (obs.contact_left || obs.contact_right)))
        enter(Stage::Close, obs);
      break;
    case Stage::Close:
      if (m_.done()) {
        if (obs.gripper_opening < robot::kJawShutM) return fail(FailureCode::GraspMissed, "grasp missed: the jaw closed on nothing");
        if (grasp_only_) return completed_step();
        enter(Stage::Lift, obs);
      }
      break;
    case Stage::Lift:
      if (m_.done()) {
        if (o->p[2] - object_z0_ < 0.5 * (m_.to().z() - m_.from().z()))
          return fail(FailureCode::GraspSlipped, "object did not rise with the tool (slipped from the jaw)");
        enter(Stage::Carry, obs);
      }
      break;
    case Stage::Carry:
      if (!(obs.contact_left || obs.contact_right) || obs.gripper_opening < robot::kJawShutM)
        return fail(FailureCode::ObjectDropped, "object dropped during the carry");
      if (m_.done()) enter(Stage::Lower, obs);
      break;
    case Stage::Lower:
      if (m_.done()) enter(cavity_ ? Stage::Insert : Stage::Release, obs);
      break;
    case Stage::Insert:
      if (m_.done()) enter(Stage::Release, obs);
      break;
    case Stage::Release:
      if (m_.done()) enter(cavity_ ? Stage::Withdraw : Stage::Retreat, obs);
      break;
    case Stage::Withdraw:
      if (m_.done()) enter(Stage::Retreat, obs);
      break;
    case Stage::Retreat:
      if (m_.done()) stage_ = Stage::Done;
      break;
    case Stage::Done:
      break;
  }
  if (stage_ == Stage::Done) return completed_step();
  ++total_steps_;
  const bool closed = stage_ == Stage::Close || stage_ == Stage::Lift || stage_ == Stage::Carry ||
                      stage_ == Stage::Lower || stage_ == Stage::Insert;
  out.action = m_.advance(obs, closed ? kGripClose : kGripOpen);
  out.stage = stage_name(stage_);
  out.planned_steps = committed_ + steps_after_[static_cast<int>(stage_)];
  out.progress = std::min(1.0, static_cast<double>(total_steps_) / out.planned_steps);
  return out;
}

}  // namespace dh::cap
