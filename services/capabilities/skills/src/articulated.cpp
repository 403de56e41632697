#include "dh/cap/articulated.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "dh/common/geometry.hpp"

namespace dh::cap {

namespace {
std::string fmt(const char* f, double a, double b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

// Common grounding: the part exists and is of `kind`, the asked state is one of two, the budget pays.
std::optional<std::string> check_part(const Bindings& args, const Observation& obs, const std::string& role,
                                      const std::string& kind, const char* s1, const char* s2, int cost,
                                      int budget_steps, const std::string& capability) {
  const std::string name = arg(args, role);
  const EntityState* e = obs.entity(name);
  if (!e) return role + " '" + name + "' is not in the scene";
  if (e->kind != kind) return "'" + name + "' is a " + e->kind + ", not a " + kind;
  const std::string state = arg(args, "state");
  if (state != s1 && state != s2) return "state '" + state + "' is neither '" + s1 + "' nor '" + s2 + "'";
  if (budget_steps < cost)
    return "budget of " + std::to_string(budget_steps) + " steps cannot pay for " + capability + "'s cost of " +
           std::to_string(cost) + " steps";
  return std::nullopt;
}
}  // namespace

// ---------------------------------------------------------------------------------------------------------
void ArticulatedSkill::begin(const Observation& obs, const Eigen::Vector3d& grip_tool, const Eigen::Quaterniond& q,
                             double opening, const Eigen::Vector3d& approach, Durations d, int cost,
                             std::optional<Eigen::Vector3d> retreat) {
  grip_tool_ = grip_tool;
  q_ = q;
  opening_ = opening;
  approach_ = approach;
  retreat_ = retreat.value_or(approach);
  d_ = d;
  cost_ = cost;
  total_steps_ = 0;
  committed_ = 0;
  stage_ = Stage::Approach;
  // From above, come down clear of whatever stands near the part (another handle, the fixture's top).
  Eigen::Vector3d start = grip_tool_ + approach_;
  if (approach_.head<2>().norm() < 1e-9) start.z() = clear_height(obs, start, 0.03, 0.03, part_);
  m_.go(obs, start, q_, steps(d_.approach));
  commit(m_.steps());
}

int ArticulatedSkill::steps_after() const {
  const int close = grasps() ? steps(d_.close) : 0, release = grasps() ? steps(d_.release) : 0;
  const int move =
      std::max(1, cost_ - steps(d_.approach) - steps(d_.descent) - close - release - steps(d_.retreat));
  const int via_leg = via_ ? steps(d_.descent / 2) : 0;  // the descent's second leg, from over the handle
  switch (stage_) {
    case Stage::Approach:
      return steps(d_.descent) + via_leg + close + move + release + steps(d_.retreat);
    case Stage::Descent:
      return via_leg + close + move + release + steps(d_.retreat);
    case Stage::Close:
      return move + release + steps(d_.retreat);
    case Stage::Move:
      return release + steps(d_.retreat);
    case Stage::Release:
      return steps(d_.retreat);
    case Stage::Retreat:
    case Stage::Done:
      return 0;
  }
  return 0;
}

SkillStep ArticulatedSkill::next(const Observation& obs) {
  SkillStep out;
  const EntityState* part = obs.entity(part_);
  // A part already in the asked state (moved by an earlier, interrupted command) completes at once.
  if (stage_ == Stage::Approach && m_.elapsed() == 0 && part && !verify(*part)) {
    SkillStep done = completed_step();
    done.reason = "already in the asked state";
    return done;
  }
  auto fail = [&](FailureCode code, const std::string& why) { return failed(out, code, why); };
  if (!part) return fail(FailureCode::EntityLost, "part '" + part_ + "' left the observation");
  bool move_finished = false;
  std::array<double, 7> move_action{};
  switch (stage_) {
    case Stage::Approach:
      if (m_.done()) {
        stage_ = Stage::Descent;
        const Eigen::Vector3d next = via_ ? *via_ : grip_tool_;
        m_.go(obs, next, q_, steps(d_.descent * std::max(1.0, (m_.to() - next).norm() / approach_.norm())));
        commit(m_.steps());
      }
      break;
    case Stage::Descent:
      if (m_.done() && via_) {
        m_.go(obs, grip_tool_, q_, steps(d_.descent / 2));
        commit(m_.steps());
        via_.reset();
      } else if (m_.done()) {
        if (grasps()) {
          stage_ = Stage::Close;
          m_.hold(obs, steps(d_.close));
          commit(m_.steps());
        } else {
          stage_ = Stage::Move;
          begin_move(obs);
          commit(move_steps());
        }
      }
      break;
    case Stage::Close:
      if (m_.done()) {
        if (obs.gripper_opening < robot::kJawShutM) return fail(FailureCode::HandleMissed, "handle missed: the jaw closed on nothing");
        stage_ = Stage::Move;
        begin_move(obs);
        commit(move_steps());
      }
      break;
    case Stage::Move:
      break;
    case Stage::Release:
      if (m_.done()) {
        stage_ = Stage::Retreat;
        m_.go(obs, geo::vec(obs.ee_p) + retreat_, geo::quat(obs.ee_q), steps(d_.retreat));
        commit(m_.steps());
      }
      break;
    case Stage::Retreat:
      if (m_.done()) {
        if (auto why = verify(*part)) return fail(FailureCode::StateNotReached, *why);
        stage_ = Stage::Done;
      }
      break;
    case Stage::Done:
      break;
  }
  if (stage_ == Stage::Move) {
    if (grasps() && obs.gripper_opening < robot::kJawShutM) return fail(FailureCode::HandleLost, "lost the handle while moving the part");
    move_action = move_step(obs, move_finished);
    if (move_finished) {
      if (grasps()) {
        stage_ = Stage::Release;
        m_.hold(obs, steps(d_.release));
      } else {
        stage_ = Stage::Retreat;
        m_.go(obs, geo::vec(obs.ee_p) + retreat_, geo::quat(obs.ee_q), steps(d_.retreat));
      }
      commit(m_.steps());
    }
  }
  static constexpr const char* names[] = {"approach", "descent", "close", "move", "release", "retreat", "done"};
  out.stage = names[static_cast<int>(stage_)];
  if (stage_ == Stage::Done) return completed_step();
  ++total_steps_;
  out.planned_steps = committed_ + steps_after();
  out.progress = std::min(1.0, static_cast<double>(total_steps_) / out.planned_steps);
  if (stage_ == Stage::Move) {
    out.action = move_action;
    return out;
  }
  const bool closed = stage_ == Stage::Close || (!grasps() && stage_ != Stage::Retreat);
  out.action = m_.advance(obs, closed ? move_grip() : grip_for_opening(opening_));
  return out;
}

// ---------------------------------------------------------------------------------------------------------
ParamTable DrawerParams::table() {
  return ParamTable("slide_drawer", {{"open_position", &open_position},
                                     {"closed_position", &closed_position},
                                     {"done_tolerance", &done_tolerance},
                                     {"hook_offset", &hook_offset},
                                     {"grasp_drop", &grasp_drop},
                                     {"pull_slack", &pull_slack},
                                     {"push_slack", &push_slack},
                                     {"bar_clearance", &bar_clearance},
                                     {"retreat_rise", &retreat_rise},
                                     {"tilt", &tilt},
                                     {"approach_distance", &approach_distance},
                                     {"slide_speed", &slide_speed},
                                     {"approach_steps", &approach_steps},
                                     {"descent_steps", &descent_steps},
                                     {"slide_min_steps", &slide_min_steps},
                                     {"slide_max_steps", &slide_max_steps},
                                     {"retreat_steps", &retreat_steps}});
}

SlideDrawerSkill::SlideDrawerSkill(const Theta& theta) { p_.table().load(theta); }

int SlideDrawerSkill::cost_steps() const {
  return steps(p_.approach_steps + p_.descent_steps + p_.slide_max_steps + p_.retreat_steps);
}

std::optional<std::string> SlideDrawerSkill::check(const Bindings& args, const Observation& obs, int budget_steps) const {
  return check_part(args, obs, "drawer", "drawer", "open", "closed", cost_steps(), budget_steps, "slide_drawer");
}

void SlideDrawerSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  part_ = arg(args, "drawer");
  open_ = arg(args, "state") == "open";
  const EntityState& d = *obs.entity(part_);
  // A closed fist, its jaw axis along the bar, comes down behind the bar to pull it out, or in front of
  // it to push it in. (Pushing on the drawer's front instead would bring the hand against the drawer above.)
  // The fist comes in level from the front, just above the bar, then drops behind it: coming down from
  // above would bring the hand (5 cm above the fingertips) against the handles of the drawers above.
  const Eigen::Vector2d f = front_of(d);
  const Eigen::Vector3d out(f.x(), f.y(), 0), up(0, 0, 1);
  const double offset = open_ ? -p_.hook_offset : p_.hook_offset;
  const Eigen::Vector3d tool = geo::vec(d.p) + out * offset + up * p_.grasp_drop;
  const double hover = open_ ? d.half_extents[2] + p_.bar_clearance + obs.gripper.pad_below_tcp - p_.grasp_drop : 0.0;
  via_.reset();
  if (open_) via_ = tool + up * hover;
  // The fist leans about the bar, its wrist back over the pull. Upright, the wrist (link 7's capsule, from 9
  // cm up the tool's axis) meets the fixture's front wherever the fixture rises over 9 cm above the handle;
  // the lean, by θ tilt once the fixture rises kFullLeanRise above the handle, keeps it off. Under a lower
  // rise it leans less, down to half: a full lean at a handle 4 cm under the top folds the elbow to its limit
  // and the fist stops above the bar, while a fist under half the lean slips over the bar under OSC's
  // compliance (measured on the goal kitchen's three drawers, seeds 21 and 23).
  constexpr double kFullLeanRise = 0.15;
  const EntityState* fixture = obs.entity(d.owner);
  const double rise = fixture ? top_of(*fixture) - tool.z() : 0.0;
  const double tilt = p_.tilt * std::clamp(rise / kFullLeanRise, 0.5, 1.0);
  const Eigen::Vector2d bar(-f.y(), f.x());
  const Eigen::Quaterniond q =
      Eigen::AngleAxisd(tilt, Eigen::Vector3d(bar.x(), bar.y(), 0)) * jaw_along(obs, bar);
  // Back off and rise clear of the drawer's walls, so the next motion does not sweep it shut.
  begin(obs, tool, q, 0.0, out * (p_.hook_offset + p_.approach_distance) + up * hover,
        {p_.approach_steps, p_.descent_steps, 0, 0, p_.retreat_steps}, cost_steps(),
        Eigen::Vector3d(out * (p_.hook_offset + p_.approach_distance) + up * p_.retreat_rise));
}

void SlideDrawerSkill::begin_move(const Observation& obs) {
  const EntityState& d = *obs.entity(part_);
  const double aim = open_ ? p_.open_position : p_.closed_position;
  const Eigen::Vector2d f = front_of(d);
  // Along the front direction: out to open (holding the bar), in to close (the fist bearing on the bar).
  const double dist = aim - d.joint + (open_ ? p_.pull_slack : -p_.push_slack);
  const Eigen::Vector3d to = geo::vec(obs.ee_p) + Eigen::Vector3d(f.x(), f.y(), 0) * dist;
  m_.go(obs, to, q_,
        std::clamp(steps(1.6 * std::abs(dist) / (p_.slide_speed * robot::kControlPeriodS)), steps(p_.slide_min_steps),
                   steps(p_.slide_max_steps)));
}

std::array<double, 7> SlideDrawerSkill::move_step(const Observation& obs, bool& finished) {
  const EntityState& d = *obs.entity(part_);
  finished = m_.done() || (open_ ? d.joint >= p_.open_position : d.joint <= p_.closed_position);
  return m_.advance(obs, kGripClose);
}

std::optional<std::string> SlideDrawerSkill::verify(const EntityState& d) const {
  if (open_ && d.joint < p_.open_position - p_.done_tolerance)
    return fmt("the drawer is out %.3f m, short of open (%.3f m)", d.joint, p_.open_position);
  if (!open_ && d.joint > p_.closed_position + p_.done_tolerance)
    return fmt("the drawer is still out %.3f m (closed within %.3f m)", d.joint, p_.closed_position + p_.done_tolerance);
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------------------
ParamTable KnobParams::table() {
  return ParamTable("turn_knob", {{"on_angle", &on_angle}, {"off_angle", &off_angle}, {"on_min", &on_min},
                                  {"off_max", &off_max}, {"contact_height", &contact_height},
                                  {"lever_half_width", &lever_half_width}, {"standoff", &standoff},
                                  {"approach_height", &approach_height}, {"approach_steps", &approach_steps},
                                  {"descent_steps", &descent_steps}, {"ramp_steps", &ramp_steps},
                                  {"retreat_steps", &retreat_steps}});
}

TurnKnobSkill::TurnKnobSkill(const Theta& theta) { p_.table().load(theta); }

int TurnKnobSkill::cost_steps() const {
  return steps(p_.approach_steps + p_.descent_steps + p_.ramp_steps + p_.retreat_steps);
}

std::optional<std::string> TurnKnobSkill::check(const Bindings& args, const Observation& obs, int budget_steps) const {
  return check_part(args, obs, "knob", "knob", "on", "off", cost_steps(), budget_steps, "turn_knob");
}

void TurnKnobSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  part_ = arg(args, "knob");
  on_ = arg(args, "state") == "on";
  const EntityState& k = *obs.entity(part_);
  // The axis runs through the lever's centre along the part's front; turning on (the angle growing about
  // the axis -front) moves the lever's top towards front × up.
  const Eigen::Quaterniond q = geo::quat(k.q);
  const Eigen::Vector3d axis = q * Eigen::Vector3d(-1, 0, 0);
  const Eigen::Vector3d up = q * Eigen::Vector3d(0, 0, 1);
  sweep_ = axis.cross(up);
  sweep_.z() = 0;
  sweep_ = (on_ ? 1.0 : -1.0) * sweep_.normalized();
  const double aim = on_ ? p_.on_angle : p_.off_angle;
  const double lever_arm = p_.contact_height + 0.006;  // the pads bear on the lever about here above the axis
  const double lead = p_.lever_half_width + p_.standoff + obs.gripper.pad_half_width;
  stroke_ = lead + lever_arm * std::tan(std::clamp(std::abs(aim - k.joint), 0.0, 1.2)) + 0.004;
  const Eigen::Vector3d start =
      geo::vec(k.p) - sweep_ * lead + Eigen::Vector3d(0, 0, p_.contact_height + obs.gripper.pad_below_tcp);
  // A closed fist with the jaw's axis along the knob's axis: the pads' 2 cm face bears on the lever.
  begin(obs, start, jaw_along(obs, Eigen::Vector2d(axis.x(), axis.y())), 0.0, {0, 0, p_.approach_height},
        {p_.approach_steps, p_.descent_steps, 0, 0, p_.retreat_steps}, cost_steps());
}

void TurnKnobSkill::begin_move(const Observation& obs) {
  m_.go(obs, geo::vec(obs.ee_p) + sweep_ * stroke_, q_, steps(p_.ramp_steps));
}

std::array<double, 7> TurnKnobSkill::move_step(const Observation& obs, bool& finished) {
  const EntityState& k = *obs.entity(part_);
  finished = m_.done() || (on_ ? k.joint >= p_.on_angle : k.joint <= p_.off_angle);
  return m_.advance(obs, kGripClose);
}

std::optional<std::string> TurnKnobSkill::verify(const EntityState& k) const {
  if (on_ && k.joint < p_.on_min) return fmt("the knob turned to %.2f rad, short of on (%.2f rad)", k.joint, p_.on_min);
  if (!on_ && k.joint > p_.off_max) return fmt("the knob rests at %.2f rad, above off (%.2f rad)", k.joint, p_.off_max);
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------------------
ParamTable DoorParams::table() {
  return ParamTable("swing_door", {{"hinge_radius", &hinge_radius}, {"handle_standoff", &handle_standoff},
                                   {"open_angle", &open_angle}, {"closed_angle", &closed_angle},
                                   {"open_max", &open_max}, {"closed_min", &closed_min},
                                   {"grasp_opening", &grasp_opening}, {"approach_height", &approach_height},
                                   {"approach_steps", &approach_steps}, {"descent_steps", &descent_steps},
                                   {"close_steps", &close_steps}, {"swing_steps", &swing_steps},
                                   {"release_steps", &release_steps}, {"retreat_steps", &retreat_steps}});
}

SwingDoorSkill::SwingDoorSkill(const Theta& theta) { p_.table().load(theta); }

int SwingDoorSkill::cost_steps() const {
  return steps(p_.approach_steps + p_.descent_steps + p_.close_steps + p_.swing_steps + p_.release_steps +
               p_.retreat_steps);
}

std::optional<std::string> SwingDoorSkill::check(const Bindings& args, const Observation& obs, int budget_steps) const {
  return check_part(args, obs, "door", "door", "open", "closed", cost_steps(), budget_steps, "swing_door");
}

void SwingDoorSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  part_ = arg(args, "door");
  open_ = arg(args, "state") == "open";
  const EntityState& d = *obs.entity(part_);
  // The hinge line from the handle: the door runs along its -y from the hinge, the handle stands off its
  // front face (-x) by the standoff.
  const Eigen::Vector3d hinge = geo::vec(d.p) + geo::quat(d.q) * Eigen::Vector3d(p_.handle_standoff, p_.hinge_radius, 0);
  hinge_ = {hinge.x(), hinge.y()};
  const Eigen::Vector2d v = Eigen::Vector2d(d.p[0], d.p[1]) - hinge_;
  radius_ = v.norm();
  phi0_ = std::atan2(v.y(), v.x());
  sweep_ = (open_ ? p_.open_angle : p_.closed_angle) - d.joint;
  z_ = d.p[2];
  // The jaw closes across the handle, along the door's face (not along hinge-to-handle, which the
  // standoff tilts by a few degrees: enough for the 20 cm hand to touch the door).
  const Eigen::Vector3d face = geo::quat(d.q) * Eigen::Vector3d(0, -1, 0);
  const Eigen::Vector2d along(face.x(), face.y());
  const Eigen::Quaterniond q = jaw_along(obs, along);
  yaw0_ = geo::tool_yaw(q);
  begin(obs, Eigen::Vector3d(d.p[0], d.p[1], z_), q, p_.grasp_opening, {0, 0, p_.approach_height},
        {p_.approach_steps, p_.descent_steps, p_.close_steps, p_.release_steps, p_.retreat_steps}, cost_steps());
}

void SwingDoorSkill::begin_move(const Observation&) {
  swing_step_ = 0;
  swing_steps_ = std::max(steps(p_.swing_steps), track_steps(radius_ * std::abs(sweep_), std::abs(sweep_)));
}

std::array<double, 7> SwingDoorSkill::move_step(const Observation& obs, bool& finished) {
  // The hand's reference on the arc, turning with the door, now and a step later.
  auto s = [&](int step) { return profile(static_cast<double>(step) / swing_steps_); };
  auto at = [&](double s) {
    const double phi = phi0_ + s * sweep_;
    return Eigen::Vector3d(hinge_.x() + radius_ * std::cos(phi), hinge_.y() + radius_ * std::sin(phi), z_);
  };
  const double now = s(swing_step_);
  swing_step_ = std::min(swing_step_ + 1, swing_steps_);
  finished = swing_step_ >= swing_steps_;
  const double next = s(swing_step_);
  return track(obs, at(now), geo::top_down(yaw0_ + now * sweep_), at(next),
               geo::top_down(yaw0_ + next * sweep_), kGripClose);
}

std::optional<std::string> SwingDoorSkill::verify(const EntityState& d) const {
  if (open_ && d.joint > p_.open_max) return fmt("the door stands at %.2f rad, short of open (%.2f rad)", d.joint, p_.open_max);
  if (!open_ && d.joint < p_.closed_min)
    return fmt("the door stands at %.3f rad, short of closed (%.3f rad)", d.joint, p_.closed_min);
  return std::nullopt;
}

}  // namespace dh::cap
