#include "dh/gov/perception.hpp"

#include <algorithm>
#include <cstdio>

namespace dh::gov {

std::optional<Unperceived> perceive(Observation& obs, const std::optional<SceneEstimate>& estimate,
                                    const std::vector<std::string>& needed, const PerceptionLimits& limits) {
  if (!estimate) return Unperceived{"no scene estimate from the perception service for this episode", true};
  if (obs.step > estimate->step + limits.max_age_steps)
    return Unperceived{"the latest scene estimate is from step " + std::to_string(estimate->step) + ", " +
                           std::to_string(obs.step - estimate->step) + " steps old (limit " +
                           std::to_string(limits.max_age_steps) + ")",
                       true};
  const auto looked_for = [&](const std::string& name) {
    return std::find(estimate->looked_for.begin(), estimate->looked_for.end(), name) != estimate->looked_for.end();
  };
  const auto seen = [&](const std::string& name) -> const PerceivedEntity* {
    for (const auto& e : estimate->seen)
      if (e.name == name && e.confidence >= limits.min_confidence) return &e;
    return nullptr;
  };
  for (const auto& name : needed)
    if (looked_for(name) && !seen(name)) {
      double best = 0;
      for (const auto& e : estimate->seen)
        if (e.name == name) best = std::max(best, e.confidence);
      char conf[64];
      std::snprintf(conf, sizeof conf, " with enough confidence (%.2f < %.2f)", best, limits.min_confidence);
      return Unperceived{"perception did not see '" + name + "' in the frame of step " + std::to_string(estimate->step) +
                             (best > 0 ? conf : ""),
                         false};
    }
  std::vector<EntityState> kept;
  for (auto& e : obs.entities) {
    if (!looked_for(e.name)) {
      kept.push_back(e);
      continue;
    }
    if (const PerceivedEntity* p = seen(e.name)) {
      e.p = p->p;
      e.half_extents = p->half_extents;
      e.q = {1, 0, 0, 0};  // upright boxes: perception estimates no tilt
      kept.push_back(e);
    }
  }
  obs.entities = std::move(kept);
  return std::nullopt;
}

}  // namespace dh::gov
