#include "dh/sim/safety.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dh::sim {

SafetyVerdict check_joint_speeds(const std::array<double, 7>& dq, const SafetyLimits& limits) {
  for (int i = 0; i < 7; ++i) {
    if (std::abs(dq[i]) > limits.joint_speed) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "joint %d speed %.3f rad/s exceeds envelope %.2f rad/s", i + 1,
                    std::abs(dq[i]), limits.joint_speed);
      return {false, i, std::abs(dq[i]), buf};
    }
  }
  return {};
}

std::optional<std::string> clamp_action(std::array<double, 7>& a) {
  std::optional<std::string> why;
  for (int i = 0; i < 7; ++i) {
    const double c = std::clamp(std::isfinite(a[i]) ? a[i] : 0.0, -1.0, 1.0);
    if (c != a[i] && !why)
      why = "action component " + std::to_string(i) + " = " + std::to_string(a[i]) +
            " is not finite or outside [-1, 1]; applied as " + std::to_string(c);
    a[i] = c;
  }
  return why;
}

bool clamp_to_workspace(std::array<double, 3>& p, const SafetyLimits& limits) {
  bool clamped = false;
  for (int i = 0; i < 3; ++i) {
    const double c = std::clamp(p[i], limits.workspace_min[i], limits.workspace_max[i]);
    clamped |= (c != p[i]);
    p[i] = c;
  }
  return clamped;
}

}  // namespace dh::sim
