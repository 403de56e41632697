// Grounding from perception (`grounding: perception` in an arm): the free objects the perception service
// looks for are placed where its latest scene estimate saw them, instead of where the simulator (or the
// robot adapter) says they are. Fixtures, their parts and regions stay where the cell's description puts
// them (a real cell calibrates those once). Pure logic, no DDS.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh::gov {

struct PerceivedEntity {
  std::string name;
  std::array<double, 3> p{};             ///< bottom centre of its box (m), as EntityState::p
  std::array<double, 3> half_extents{};  ///< m
  double confidence = 0;                 ///< 0..1
};

/// One frame's estimates from the perception service.
struct SceneEstimate {
  std::string episode_id;
  std::uint32_t step = 0;              ///< the control step of the frame
  std::vector<std::string> looked_for;  ///< every entity the service tried to find in the frame
  std::vector<PerceivedEntity> seen;    ///< those it found
};

struct PerceptionLimits {
  std::uint32_t max_age_steps = 20;  ///< an estimate older than this (1 s at 20 Hz) is stale
  double min_confidence = 0.3;       ///< below this an entity counts as not seen
  std::chrono::milliseconds wait{3000};  ///< how long grounding waits for a fresh estimate before refusing
};

/// Why grounding cannot go on from what perception saw.
struct Unperceived {
  std::string reason;
  bool estimate_missing_or_stale = false;  ///< a fresh estimate may still come (worth waiting for)
};

/// Rewrites `obs` as perception sees it: each entity the estimate looked for takes its seen position and
/// size, or leaves the scene when it was not seen (or too uncertainly). Returns why grounding must refuse
/// — no estimate, a stale one, or an entity of `needed` that was looked for and not seen — or nullopt.
std::optional<Unperceived> perceive(Observation& obs, const std::optional<SceneEstimate>& estimate,
                                    const std::vector<std::string>& needed, const PerceptionLimits& limits);

}  // namespace dh::gov
