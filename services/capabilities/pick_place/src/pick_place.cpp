#include "dh/cap/pick_place.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dh/common/geometry.hpp"

namespace dh::cap {

namespace {
constexpr double kMaxDeltaPos = 0.05, kMaxDeltaRot = 0.5;  // OSC_POSE scaling
constexpr double kGripOpen = -1.0, kGripClose = 1.0;
constexpr double kMaxJaw = 0.08;  // m, full opening of the parallel jaw

double top_of(const EntityState& e) { return e.p[2] + 2 * e.half_extents[2]; }
bool is_round(const EntityState& e) { return e.kind == "bowl" || e.kind == "plate" || e.kind == "cylinder"; }
}  // namespace

PickPlaceParams PickPlaceParams::from_map(const std::map<std::string, double>& theta) {
  PickPlaceParams p;
  std::map<std::string, double*> doubles{{"approach_height", &p.approach_height},
                                         {"corridor_height", &p.corridor_height},
                                         {"rim_grasp_depth", &p.rim_grasp_depth},
                                         {"place_clearance", &p.place_clearance},
                                         {"max_speed", &p.max_speed},
                                         {"retreat_height", &p.retreat_height}};
  std::map<std::string, int*> ints{{"approach_steps", &p.approach_steps}, {"descent_steps", &p.descent_steps},
                                   {"close_steps", &p.close_steps},       {"lift_steps", &p.lift_steps},
                                   {"carry_min_steps", &p.carry_min_steps}, {"carry_max_steps", &p.carry_max_steps},
                                   {"lower_steps", &p.lower_steps},       {"release_steps", &p.release_steps},
                                   {"retreat_steps", &p.retreat_steps}};
  for (const auto& [name, value] : theta) {
    if (auto d = doubles.find(name); d != doubles.end()) *d->second = value;
    else if (auto i = ints.find(name); i != ints.end()) *i->second = static_cast<int>(std::lround(value));
    else throw std::invalid_argument("pick_place has no parameter '" + name + "'");
  }
  return p;
}

std::map<std::string, double> PickPlaceParams::to_map() const {
  return {{"approach_height", approach_height}, {"corridor_height", corridor_height},
          {"rim_grasp_depth", rim_grasp_depth}, {"place_clearance", place_clearance},
          {"max_speed", max_speed},             {"retreat_height", retreat_height},
          {"approach_steps", approach_steps},   {"descent_steps", descent_steps},
          {"close_steps", close_steps},         {"lift_steps", lift_steps},
          {"carry_min_steps", carry_min_steps}, {"carry_max_steps", carry_max_steps},
          {"lower_steps", lower_steps},         {"release_steps", release_steps},
          {"retreat_steps", retreat_steps}};
}

int PickPlaceParams::cost_steps() const {
  return approach_steps + descent_steps + close_steps + lift_steps + carry_max_steps + lower_steps +
         release_steps + retreat_steps;
}

std::optional<std::string> PickPlaceSkill::check(const std::string& object, const std::string& target,
                                                 const Observation& obs, int budget_steps) const {
  const EntityState* o = obs.entity(object);
  const EntityState* t = obs.entity(target);
  if (!o) return "object '" + object + "' is not in the scene";
  if (!t) return "target '" + target + "' is not in the scene";
  if (object == target) return "object and target are the same entity '" + object + "'";
  if (o->kind == "plate") return "a plate has no rim or sides the jaw can hold";
  if (o->kind != "bowl" && 2 * std::min(o->half_extents[0], o->half_extents[1]) > kMaxJaw - 0.01)
    return "object '" + object + "' is wider than the jaw opens";
  if (budget_steps < p_.cost_steps())
    return "budget of " + std::to_string(budget_steps) + " steps cannot pay for pick_place's cost of " +
           std::to_string(p_.cost_steps()) + " steps";
  return std::nullopt;
}

void PickPlaceSkill::start(const std::string& object, const std::string& target, const Observation& obs) {
  object_ = object;
  target_ = target;
  total_steps_ = 0;
  const EntityState& o = *obs.entity(object);
  const Eigen::Vector3d c = geo::vec(o.p);
  const Eigen::Vector3d ee = geo::vec(obs.ee_p);
  const double ee_yaw = geo::tool_yaw(geo::quat(obs.ee_q));
  double yaw;
  if (o.kind == "bowl") {
    // Pinch the rim at the point nearest the tool; the jaw closes across the wall (radially).
    const double phi = std::atan2(ee.y() - c.y(), ee.x() - c.x());
    const double r = o.half_extents[0] - 0.004;  // wall centre line (half the wall thickness in)
    grasp_ = {c.x() + r * std::cos(phi), c.y() + r * std::sin(phi), top_of(o) - p_.rim_grasp_depth};
    yaw = phi + std::numbers::pi / 2;
  } else {
    // Close across the narrow side of a box, at half its height (a cylinder: any side).
    const double obj_yaw = geo::tool_yaw(geo::quat(o.q));
    const bool narrow_x = is_round(o) || o.half_extents[0] <= o.half_extents[1];
    yaw = narrow_x ? obj_yaw + std::numbers::pi / 2 : obj_yaw;
    grasp_ = {c.x(), c.y(), o.p[2] + std::max(o.half_extents[2], 2 * o.half_extents[2] - 0.03)};
  }
  // The jaw is symmetric: of yaw and yaw+π take the one closer to the tool's current yaw.
  if (std::abs(geo::wrap(yaw - ee_yaw)) > std::numbers::pi / 2) yaw += std::numbers::pi;
  grasp_q_ = geo::top_down(geo::wrap(yaw));
  enter(Stage::Approach, obs);
}

const char* PickPlaceSkill::stage_name(Stage s) {
  switch (s) {
    case Stage::Approach: return "approach";
    case Stage::Descent: return "guarded_descent";
    case Stage::Close: return "close";
    case Stage::Lift: return "lift";
    case Stage::Carry: return "carry";
    case Stage::Lower: return "lower";
    case Stage::Release: return "release";
    case Stage::Retreat: return "retreat";
    case Stage::Done: return "done";
  }
  return "?";
}

void PickPlaceSkill::enter(Stage s, const Observation& obs) {
  stage_ = s;
  stage_step_ = 0;
  const Eigen::Vector3d ee = geo::vec(obs.ee_p);
  const Eigen::Quaterniond eq = geo::quat(obs.ee_q);
  seg_.from = ee;
  seg_.q_from = eq;
  seg_.q_to = eq;
  seg_.to = ee;
  switch (s) {
    case Stage::Approach:
      seg_.to = grasp_ + Eigen::Vector3d(0, 0, p_.approach_height);
      seg_.q_to = grasp_q_;
      seg_.steps = p_.approach_steps;
      break;
    case Stage::Descent:
      seg_.to = grasp_;
      seg_.q_to = grasp_q_;
      seg_.steps = p_.descent_steps;
      break;
    case Stage::Close:
    case Stage::Release:
      seg_.steps = s == Stage::Close ? p_.close_steps : p_.release_steps;
      break;
    case Stage::Lift: {
      const EntityState& o = *obs.entity(object_);
      object_z0_ = o.p[2];
      grasp_offset_ = {ee.x() - o.p[0], ee.y() - o.p[1]};
      grasp_height_ = ee.z() - o.p[2];
      seg_.to = {ee.x(), ee.y(), p_.corridor_height + grasp_height_};
      seg_.q_to = grasp_q_;
      seg_.steps = p_.lift_steps;
      break;
    }
    case Stage::Carry: {
      const EntityState& t = *obs.entity(target_);
      seg_.to = {t.p[0] + grasp_offset_.x(), t.p[1] + grasp_offset_.y(), ee.z()};
      const double dist = (seg_.to - seg_.from).norm();
      seg_.steps = std::clamp(static_cast<int>(std::ceil(dist / (p_.max_speed * 0.05) * 1.9)),
                              p_.carry_min_steps, p_.carry_max_steps);
      seg_.q_to = grasp_q_;
      break;
    }
    case Stage::Lower: {
      const EntityState& t = *obs.entity(target_);
      seg_.to = {t.p[0] + grasp_offset_.x(), t.p[1] + grasp_offset_.y(),
                 top_of(t) + p_.place_clearance + grasp_height_};
      seg_.q_to = grasp_q_;
      seg_.steps = p_.lower_steps;
      break;
    }
    case Stage::Retreat:
      seg_.to = ee + Eigen::Vector3d(0, 0, p_.retreat_height);
      seg_.steps = p_.retreat_steps;
      break;
    case Stage::Done:
      break;
  }
}

SkillStep PickPlaceSkill::act(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                              double grip) {
  SkillStep out;
  const Eigen::Vector3d dp = (p - geo::vec(obs.ee_p)) / kMaxDeltaPos;
  const Eigen::Vector3d dr = geo::rotvec_between(geo::quat(obs.ee_q), q) / kMaxDeltaRot;
  for (int i = 0; i < 3; ++i) {
    out.action[i] = std::clamp(dp[i], -1.0, 1.0);
    out.action[3 + i] = std::clamp(dr[i], -1.0, 1.0);
  }
  out.action[6] = grip;
  out.stage = stage_name(stage_);
  out.progress = std::min(1.0, static_cast<double>(total_steps_) / p_.cost_steps());
  return out;
}

SkillStep PickPlaceSkill::next(const Observation& obs) {
  const EntityState* o = obs.entity(object_);
  if (!o || !obs.entity(target_)) {
    SkillStep f;
    f.status = SkillStatus::Failed;
    f.reason = "entity '" + (o ? target_ : object_) + "' left the observation";
    f.stage = stage_name(stage_);
    return f;
  }
  // Stage transitions driven by what is observed.
  const bool seg_done = stage_step_ >= seg_.steps;
  const double ee_err = (geo::vec(obs.ee_p) - seg_.to).norm();
  auto fail = [&](const std::string& why) {
    SkillStep f;
    f.status = SkillStatus::Failed;
    f.stage = stage_name(stage_);
    f.reason = why;
    f.action = {0, 0, 0, 0, 0, 0, 0};
    return f;
  };
  switch (stage_) {
    case Stage::Approach:
      if (seg_done) enter(Stage::Descent, obs);
      break;
    case Stage::Descent:
      // Guarded: stop early when a finger touches something or the target is reached.
      if (seg_done || ee_err < 0.003 || (stage_step_ > 3 && (obs.contact_left || obs.contact_right)))
        enter(Stage::Close, obs);
      break;
    case Stage::Close:
      if (seg_done) {
        if (obs.gripper_opening < 0.002) return fail("grasp missed: the jaw closed on nothing");
        enter(Stage::Lift, obs);
      }
      break;
    case Stage::Lift:
      if (seg_done) {
        if (o->p[2] - object_z0_ < 0.5 * (seg_.to.z() - seg_.from.z()))
          return fail("object did not rise with the tool (slipped from the jaw)");
        enter(Stage::Carry, obs);
      }
      break;
    case Stage::Carry:
      if (!(obs.contact_left || obs.contact_right) || obs.gripper_opening < 0.002)
        return fail("object dropped during the carry");
      if (seg_done) enter(Stage::Lower, obs);
      break;
    case Stage::Lower:
      if (seg_done) enter(Stage::Release, obs);
      break;
    case Stage::Release:
      if (seg_done) enter(Stage::Retreat, obs);
      break;
    case Stage::Retreat:
      if (seg_done) {
        stage_ = Stage::Done;
        SkillStep done;
        done.status = SkillStatus::Completed;
        done.stage = "done";
        done.progress = 1.0;
        return done;
      }
      break;
    case Stage::Done: {
      SkillStep done;
      done.status = SkillStatus::Completed;
      done.stage = "done";
      done.progress = 1.0;
      return done;
    }
  }
  ++stage_step_;
  ++total_steps_;
  // Waypoint for this step along the stage's smooth profile.
  const double s = geo::smooth(static_cast<double>(stage_step_) / std::max(1, seg_.steps));
  const Eigen::Vector3d wp = seg_.from + s * (seg_.to - seg_.from);
  const Eigen::Quaterniond wq = seg_.q_from.slerp(s, seg_.q_to);
  const bool closed = stage_ == Stage::Close || stage_ == Stage::Lift || stage_ == Stage::Carry ||
                      stage_ == Stage::Lower;
  return act(obs, wp, wq, closed ? kGripClose : kGripOpen);
}

}  // namespace dh::cap
