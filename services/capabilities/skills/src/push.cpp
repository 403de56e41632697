#include "dh/cap/push.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dh/common/geometry.hpp"

namespace dh::cap {

namespace {
bool round(const EntityState& e) { return e.kind == "bowl" || e.kind == "plate" || e.kind == "mug"; }

// Width across the push: a round body's diameter (a mug's handle aside), else the box's larger side.
double width_of(const EntityState& e) {
  return 2 * (round(e) ? std::min(e.half_extents[0], e.half_extents[1]) : std::max(e.half_extents[0], e.half_extents[1]));
}

// Distance from the object's centre to its face the pads meet when pushing along `d` (its support in -d).
double support(const EntityState& e, const Eigen::Vector2d& d) {
  if (round(e)) return std::min(e.half_extents[0], e.half_extents[1]);
  const double yaw = geo::tool_yaw(geo::quat(e.q));
  const Eigen::Vector2d ex(std::cos(yaw), std::sin(yaw)), ey(-std::sin(yaw), std::cos(yaw));
  return std::abs(d.dot(ex)) * e.half_extents[0] + std::abs(d.dot(ey)) * e.half_extents[1];
}
bool in_region(const EntityState& r, const EntityState& o, double margin) {
  return std::abs(o.p[0] - r.p[0]) < r.half_extents[0] - margin && std::abs(o.p[1] - r.p[1]) < r.half_extents[1] - margin;
}
}  // namespace

ParamTable PushParams::table() {
  return ParamTable("push", {{"contact_fraction", &contact_fraction}, {"push_opening", &push_opening},
                             {"push_height", &push_height}, {"standoff", &standoff},
                             {"approach_height", &approach_height}, {"max_speed", &max_speed},
                             {"approach_steps", &approach_steps}, {"descent_steps", &descent_steps},
                             {"lead", &lead}, {"done_distance", &done_distance}, {"push_max_steps", &push_max_steps},
                             {"back_off_steps", &back_off_steps}, {"retreat_steps", &retreat_steps}});
}

PushSkill::PushSkill(const Theta& theta) { p_.table().load(theta); }

int PushSkill::cost_steps() const {
  return steps(p_.approach_steps + p_.descent_steps + p_.push_max_steps + p_.back_off_steps + p_.retreat_steps);
}

std::optional<std::string> PushSkill::check(const Bindings& args, const Observation& obs, int budget_steps) const {
  const std::string object = arg(args, "object"), target = arg(args, "target");
  const EntityState* o = obs.entity(object);
  const EntityState* t = obs.entity(target);
  if (!o) return "object '" + object + "' is not in the scene";
  if (!t) return "target '" + target + "' is not in the scene";
  if (part_or_region(*o)) return "'" + object + "' is a " + o->kind + ", not an object a push can move";
  if (t->kind != "region") return "target '" + target + "' is not a table region an object can be pushed into";
  const double need = p_.contact_fraction * width_of(*o);
  const double span = p_.push_opening + 2 * obs.gripper.pad_thickness;
  if (need > span) {
    char why[256];
    std::snprintf(why, sizeof why,
                  "the jaw is too narrow for the contact the push requires: '%s' is %.3f m wide, a stable push "
                  "needs %.3f m of contact (contact_fraction %.2f), the jaw spans %.3f m",
                  object.c_str(), width_of(*o), need, p_.contact_fraction, span);
    return std::string(why);
  }
  if (budget_steps < cost_steps())
    return "budget of " + std::to_string(budget_steps) + " steps cannot pay for push's cost of " +
           std::to_string(cost_steps()) + " steps";
  return std::nullopt;
}

void PushSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  object_ = arg(args, "object");
  target_ = arg(args, "target");
  total_steps_ = 0;
  const EntityState& o = *obs.entity(object_);
  const EntityState& t = *obs.entity(target_);
  object0_ = {o.p[0], o.p[1]};
  const Eigen::Vector2d to(t.p[0], t.p[1]);
  travel_ = (to - object0_).norm();
  dir_ = travel_ > 1e-6 ? Eigen::Vector2d((to - object0_) / travel_) : Eigen::Vector2d(1, 0);
  const Eigen::Vector2d behind = object0_ - dir_ * (support(o, dir_) + p_.standoff + obs.gripper.pad_thickness / 2);
  start_ = {behind.x(), behind.y(), o.p[2] + p_.push_height + obs.gripper.pad_below_tcp};
  // The jaw's axis (tool y) across the push, so both open fingers bear on the object.
  double yaw = std::atan2(dir_.y(), dir_.x());
  if (std::abs(geo::wrap(yaw - geo::tool_yaw(geo::quat(obs.ee_q)))) > std::numbers::pi / 2) yaw += std::numbers::pi;
  q_ = geo::top_down(geo::wrap(yaw));
  stage_ = Stage::Approach;
  m_.go(obs, start_ + Eigen::Vector3d(0, 0, p_.approach_height), q_, steps(p_.approach_steps));
}

void PushSkill::back_off(const Observation& obs) {
  // Straight back from the object first, so the open fingers cannot lift it on the way up.
  stage_ = Stage::BackOff;
  m_.go(obs, geo::vec(obs.ee_p) - Eigen::Vector3d(dir_.x(), dir_.y(), 0) * p_.standoff, q_, steps(p_.back_off_steps));
}

SkillStep PushSkill::next(const Observation& obs) {
  SkillStep out;
  const EntityState* o = obs.entity(object_);
  const EntityState* t = obs.entity(target_);
  static constexpr const char* names[] = {"approach", "descent", "push", "back_off", "retreat", "done"};
  auto fail = [&](FailureCode code, const std::string& why) {
    out.stage = names[static_cast<int>(stage_)];
    return failed(out, code, why);
  };
  if (!o || !t) return fail(FailureCode::EntityLost, "entity '" + (o ? target_ : object_) + "' left the observation");
  const Eigen::Vector2d now(o->p[0], o->p[1]);
  switch (stage_) {
    case Stage::Approach:
      if (m_.done()) {
        stage_ = Stage::Descent;
        m_.go(obs, start_, q_, steps(p_.descent_steps));
      }
      break;
    case Stage::Descent:
      if (m_.done() || (m_.elapsed() > 3 && (obs.contact_left || obs.contact_right))) {
        stage_ = Stage::Push;
        push_steps_ = 0;
        reference_ = 0;
      }
      break;
    case Stage::Push: {
      // A reference for the object's centre runs from where it started to the region's centre at
      // max_speed; the pads aim `lead` into the object behind the reference, centred on the object's
      // sideways drift. The reference waits while the object lags more than 3 cm, so a sticking object
      // is pressed harder but never overtaken.
      const Eigen::Vector2d goal(t->p[0], t->p[1]);
      const double left = (goal - now).norm();
      if (left < p_.done_distance || (in_region(*t, *o, 0.015) && left < 2 * p_.done_distance)) {
        back_off(obs);
        break;
      }
      if (++push_steps_ > steps(p_.push_max_steps)) {
        if (in_region(*t, *o, 0.0)) {
          back_off(obs);
          break;
        }
        return fail(FailureCode::PushExhausted, "push ran out of its " + std::to_string(steps(p_.push_max_steps)) + " steps " +
                    std::to_string(left) + " m short of '" + target_ + "'");
      }
      const double along = (now - object0_).dot(dir_);
      const Eigen::Vector2d ee(obs.ee_p[0], obs.ee_p[1]);
      if ((now - ee).dot(dir_) < 0) return fail(FailureCode::ContactLost, "object slid off the pusher (it is no longer ahead of the pads)");
      const double before = reference_;
      if (reference_ - along < 0.03) reference_ = std::min(travel_, reference_ + p_.max_speed * robot::kControlPeriodS);
      const Eigen::Vector2d side(-dir_.y(), dir_.x());
      auto pads_at = [&](double reference) {
        const Eigen::Vector2d centre = object0_ + dir_ * reference + side * (now - object0_).dot(side);
        const Eigen::Vector2d to = centre - dir_ * (support(*o, dir_) + obs.gripper.pad_thickness / 2 - p_.lead);
        return Eigen::Vector3d(to.x(), to.y(), start_.z());
      };
      const Eigen::Vector3d to = pads_at(reference_);
      ++total_steps_;
      out.stage = "push";
      // Before contact the tool closes the standoff at max_speed, not in one lunge; then it tracks the
      // pads' reference.
      const Eigen::Vector3d ee3(ee.x(), ee.y(), start_.z());
      const double reach = p_.lead + p_.max_speed * robot::kControlPeriodS;
      if ((to - ee3).norm() > reach) {
        const Eigen::Vector3d step = (to - ee3).normalized() * p_.max_speed * robot::kControlPeriodS;
        out.action = track(obs, ee3, q_, ee3 + step, q_, grip_for_opening(p_.push_opening));
      } else {
        out.action = track(obs, pads_at(before), q_, to, q_, grip_for_opening(p_.push_opening));
      }
      out.progress = std::min(1.0, along / std::max(travel_, 1e-6));
      return out;
    }
    case Stage::BackOff:
      if (m_.done()) {
        stage_ = Stage::Retreat;
        m_.go(obs, geo::vec(obs.ee_p) + Eigen::Vector3d(0, 0, p_.approach_height), q_, steps(p_.retreat_steps));
      }
      break;
    case Stage::Retreat:
      if (m_.done()) stage_ = Stage::Done;
      break;
    case Stage::Done:
      break;
  }
  if (stage_ == Stage::Done) return completed_step();
  ++total_steps_;
  out.stage = names[static_cast<int>(stage_)];
  out.action = m_.advance(obs, grip_for_opening(p_.push_opening));
  out.progress = std::min(1.0, static_cast<double>(total_steps_) / cost_steps());
  return out;
}

}  // namespace dh::cap
