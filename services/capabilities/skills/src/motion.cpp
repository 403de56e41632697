#include "dh/cap/motion.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dh/common/geometry.hpp"
#include "dh/common/robot_contract.hpp"

namespace dh::cap {

namespace {
constexpr double kRamp = 0.25;               // share of a motion's time its speed rises (and falls) over
constexpr double kPeak = 1.0 / (1 - kRamp);  // peak speed over mean speed

/// Scales `v` down, its direction kept, so no component exceeds 1 in magnitude.
Eigen::Vector3d within_unit(const Eigen::Vector3d& v) { return v / std::max(1.0, v.cwiseAbs().maxCoeff()); }
}  // namespace

double profile(double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  if (tau > 1 - kRamp) return 1 - profile(1 - tau);
  if (tau < kRamp)
    return kPeak * (tau / 2 - kRamp / (2 * std::numbers::pi) * std::sin(std::numbers::pi * tau / kRamp));
  return kPeak * (tau - kRamp / 2);
}

int track_steps(double distance, double turn) {
  const double step = kTrackShare * robot::kOscStepShare * robot::kMaxDeltaPosM;  // m a step at the peak
  const double turn_step = kMaxTurnRadS * robot::kControlPeriodS;                 // rad a step at the peak
  return static_cast<int>(std::ceil(kPeak * std::max(distance / step, turn / turn_step)));
}

void Motion::go(const Observation& obs, const Eigen::Vector3d& to, const Eigen::Quaterniond& q_to, int steps) {
  from_ = geo::vec(obs.ee_p);
  q_from_ = geo::quat(obs.ee_q);
  to_ = to;
  q_to_ = q_to;
  steps_ = std::max({1, steps, track_steps((to_ - from_).norm(), q_from_.angularDistance(q_to_))});
  step_ = 0;
}

void Motion::hold(const Observation& obs, int steps) {
  go(obs, geo::vec(obs.ee_p), geo::quat(obs.ee_q), steps);
}

double Motion::error(const Observation& obs) const { return (geo::vec(obs.ee_p) - to_).norm(); }

Eigen::Vector3d Motion::p_at(int step) const {
  return from_ + profile(static_cast<double>(step) / steps_) * (to_ - from_);
}

Eigen::Quaterniond Motion::q_at(int step) const {
  return q_from_.slerp(profile(static_cast<double>(step) / steps_), q_to_);
}

std::array<double, 7> Motion::advance(const Observation& obs, double grip) {
  const int now = step_;
  step_ = std::min(step_ + 1, steps_);
  return track(obs, p_at(now), q_at(now), p_at(step_), q_at(step_), grip);
}

std::array<double, 7> track(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                            const Eigen::Vector3d& p_next, const Eigen::Quaterniond& q_next, double grip) {
  const Eigen::Quaterniond ee_q = geo::quat(obs.ee_q);
  const Eigen::Vector3d dp = p - geo::vec(obs.ee_p) + (p_next - p) / robot::kOscStepShare;
  const Eigen::Vector3d dr =
      geo::rotvec_between(ee_q, q) + geo::rotvec_between(q, q_next) / robot::kOscStepShare;
  const Eigen::Vector3d ap = within_unit(dp / robot::kMaxDeltaPosM),
                        ar = within_unit(dr / robot::kMaxDeltaRotRad);
  return {ap.x(), ap.y(), ap.z(), ar.x(), ar.y(), ar.z(), grip};
}

std::array<double, 7> action_towards(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                                     double grip) {
  return track(obs, p, q, p, q, grip);
}

Eigen::Quaterniond jaw_along(const Observation& obs, const Eigen::Vector2d& axis) {
  // top_down(yaw) has its y axis along (sin yaw, -cos yaw).
  double yaw = std::atan2(axis.x(), -axis.y());
  if (std::abs(geo::wrap(yaw - geo::tool_yaw(geo::quat(obs.ee_q)))) > std::numbers::pi / 2) yaw += std::numbers::pi;
  return geo::top_down(geo::wrap(yaw));
}

Eigen::Vector2d front_of(const EntityState& part) {
  const Eigen::Vector3d f = geo::quat(part.q) * Eigen::Vector3d(-1, 0, 0);
  return Eigen::Vector2d(f.x(), f.y()).normalized();
}

bool part_or_region(const EntityState& e) {
  return e.kind == "region" || e.kind == "drawer" || e.kind == "knob" || e.kind == "door";
}

double top_of(const EntityState& e) {
  // Regions and articulated parts are observed at their centre; objects and fixtures at their bottom.
  if (part_or_region(e)) return e.p[2] + e.half_extents[2];
  return e.p[2] + 2 * e.half_extents[2];
}

double clear_height(const Observation& obs, const Eigen::Vector3d& at, double reach, double clearance,
                    const std::string& except) {
  double z = at.z();
  for (const auto& e : obs.entities) {
    if (e.kind == "region" || e.name == except) continue;
    if (std::abs(at.x() - e.p[0]) < e.half_extents[0] + reach && std::abs(at.y() - e.p[1]) < e.half_extents[1] + reach)
      z = std::max(z, top_of(e) + clearance);
  }
  return z;
}

double path_height(const Observation& obs, const Eigen::Vector2d& from, const Eigen::Vector2d& to, double reach,
                   double clearance, double floor, const std::vector<std::string>& skip) {
  double z = floor;
  for (const auto& e : obs.entities) {
    if (std::find(skip.begin(), skip.end(), e.name) != skip.end()) continue;
    for (int i = 0; i <= 20; ++i) {
      const Eigen::Vector2d p = from + (to - from) * (i / 20.0);
      if (std::abs(p.x() - e.p[0]) < e.half_extents[0] + reach && std::abs(p.y() - e.p[1]) < e.half_extents[1] + reach) {
        z = std::max(z, top_of(e) + clearance);
        break;
      }
    }
  }
  return z;
}


}  // namespace dh::cap
