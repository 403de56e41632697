#include "dh/cap/motion.hpp"

#include <algorithm>
#include <numbers>

#include "dh/common/geometry.hpp"
#include "dh/common/robot_contract.hpp"

namespace dh::cap {

void Motion::go(const Observation& obs, const Eigen::Vector3d& to, const Eigen::Quaterniond& q_to, int steps) {
  from_ = geo::vec(obs.ee_p);
  q_from_ = geo::quat(obs.ee_q);
  to_ = to;
  q_to_ = q_to;
  steps_ = std::max(1, steps);
  step_ = 0;
}

void Motion::hold(const Observation& obs, int steps) {
  go(obs, geo::vec(obs.ee_p), geo::quat(obs.ee_q), steps);
}

double Motion::error(const Observation& obs) const { return (geo::vec(obs.ee_p) - to_).norm(); }

std::array<double, 7> Motion::advance(const Observation& obs, double grip) {
  step_ = std::min(step_ + 1, steps_);
  const double s = geo::smooth(static_cast<double>(step_) / steps_);
  return action_towards(obs, from_ + s * (to_ - from_), q_from_.slerp(s, q_to_), grip);
}

std::array<double, 7> action_towards(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q,
                                     double grip) {
  std::array<double, 7> a{};
  const Eigen::Vector3d dp = (p - geo::vec(obs.ee_p)) / robot::kMaxDeltaPosM;
  const Eigen::Vector3d dr = geo::rotvec_between(geo::quat(obs.ee_q), q) / robot::kMaxDeltaRotRad;
  for (int i = 0; i < 3; ++i) {
    a[i] = std::clamp(dp[i], -1.0, 1.0);
    a[3 + i] = std::clamp(dr[i], -1.0, 1.0);
  }
  a[6] = grip;
  return a;
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

double top_of(const EntityState& e) {
  // Regions and articulated parts are observed at their centre; objects and fixtures at their bottom.
  if (e.kind == "region" || e.kind == "drawer" || e.kind == "knob" || e.kind == "door") return e.p[2] + e.half_extents[2];
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
