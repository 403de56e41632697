#include "dh/cap/recovery.hpp"

#include <cmath>

#include "dh/common/geometry.hpp"

namespace dh::cap {

namespace {

std::optional<std::string> check_budget(int budget_steps, int cost, const char* capability) {
  if (budget_steps < cost)
    return "budget of " + std::to_string(budget_steps) + " steps cannot pay for " + capability + "'s cost of " +
           std::to_string(cost) + " steps";
  return std::nullopt;
}

SkillStep running(const char* stage, std::array<double, 7> action, int done, int cost) {
  SkillStep s;
  s.stage = stage;
  s.action = action;
  s.progress = std::min(1.0, static_cast<double>(done) / cost);
  return s;
}

}  // namespace

ParamTable KeyframeParams::table() {
  return ParamTable("keyframe_return", {{"lift", &lift}, {"min_distance", &min_distance},
                                        {"lift_steps", &lift_steps}, {"return_steps", &return_steps}});
}

KeyframeReturnSkill::KeyframeReturnSkill(const Theta& theta) { p_.table().load(theta); }

int KeyframeReturnSkill::cost_steps() const { return steps(p_.lift_steps + p_.return_steps); }

std::optional<std::string> KeyframeReturnSkill::check(const Bindings&, const Observation&, int budget_steps) const {
  return check_budget(budget_steps, cost_steps(), "keyframe_return");
}

void KeyframeReturnSkill::start(const Bindings&, const Observation& obs, const SkillContext& ctx) {
  // The latest keyframe away from here; without one, the pose 0.15 m above the tool (a safe default
  // the check cannot refuse, as the episode's first command always records one).
  const Eigen::Vector3d ee = geo::vec(obs.ee_p);
  target_ = {obs.step, {ee.x(), ee.y(), ee.z() + 0.15}, obs.ee_q};
  for (auto k = ctx.keyframes.rbegin(); k != ctx.keyframes.rend(); ++k)
    if ((geo::vec(k->p) - ee).norm() >= p_.min_distance) {
      target_ = *k;
      break;
    }
  lifting_ = true;
  total_steps_ = 0;
  m_.go(obs, ee + Eigen::Vector3d(0, 0, p_.lift), geo::quat(obs.ee_q), steps(p_.lift_steps));
}

SkillStep KeyframeReturnSkill::next(const Observation& obs) {
  if (m_.done()) {
    if (!lifting_) return completed_step();
    lifting_ = false;
    m_.go(obs, geo::vec(target_.p), geo::quat(target_.q), steps(p_.return_steps));
  }
  ++total_steps_;
  return running(lifting_ ? "lift" : "return", m_.advance(obs, kGripOpen), total_steps_, cost_steps());
}

ParamTable ReleaseRetreatParams::table() {
  return ParamTable("release_retreat", {{"retreat_height", &retreat_height}, {"release_steps", &release_steps},
                                        {"retreat_steps", &retreat_steps}});
}

ReleaseRetreatSkill::ReleaseRetreatSkill(const Theta& theta) { p_.table().load(theta); }

int ReleaseRetreatSkill::cost_steps() const { return steps(p_.release_steps + p_.retreat_steps); }

std::optional<std::string> ReleaseRetreatSkill::check(const Bindings&, const Observation&, int budget_steps) const {
  return check_budget(budget_steps, cost_steps(), "release_retreat");
}

void ReleaseRetreatSkill::start(const Bindings&, const Observation& obs, const SkillContext&) {
  releasing_ = true;
  total_steps_ = 0;
  m_.hold(obs, steps(p_.release_steps));
}

SkillStep ReleaseRetreatSkill::next(const Observation& obs) {
  if (m_.done()) {
    if (!releasing_) return completed_step();
    releasing_ = false;
    m_.go(obs, geo::vec(obs.ee_p) + Eigen::Vector3d(0, 0, p_.retreat_height), geo::quat(obs.ee_q),
          steps(p_.retreat_steps));
  }
  ++total_steps_;
  return running(releasing_ ? "release" : "retreat", m_.advance(obs, kGripOpen), total_steps_, cost_steps());
}

}  // namespace dh::cap
