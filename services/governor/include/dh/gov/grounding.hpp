// Grounding G(z, c) -> command or refusal: the first half of the execution contract. The advisory is
// symbolic; grounding checks the registry, resolves every argument against the observed scene, checks
// the capability's declared preconditions and whether the remaining budget pays for its cost model.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>

#include "dh/common/grounding_refusal.hpp"
#include "dh/common/observation.hpp"
#include "dh/gov/registry.hpp"
#include "dh/gov/types.hpp"

namespace dh::gov {

using dh::Refusal;

struct GroundingResult {
  std::optional<Command> command;  ///< set when grounded
  Refusal refusal = Refusal::PlannerRefused;
  std::string reason;              ///< set when refused
};

struct GroundingInput {
  const Advice& advice;
  const Registry& registry;
  const Observation& obs;
  std::uint32_t remaining_steps;
  const std::set<std::string>& masked;  ///< capabilities the executor configuration switches off
  std::string command_id;
  std::uint32_t decision_period;  ///< steps between decisions (the lease length)
  /// θ by capability of the episode's library; a capability it lacks runs with its announced θ.
  const std::map<std::string, std::map<std::string, double>>& library;
  /// Cost under that θ by capability; a capability it lacks is budgeted by its announced cost.
  const std::map<std::string, std::uint32_t>& library_costs;
};

GroundingResult ground(const GroundingInput& in);

/// The command's budget: the cost model × 1.5 + 10 steps, never more than what remains. (MoveIt allows its
/// expected duration × 1.1 + 0.5 s; analytic skills stretch their stages with the path's length and
/// height, so the nominal cost needs the wider margin.)
std::uint32_t command_budget(std::uint32_t cost_steps, std::uint32_t remaining_steps);
/// A running command's budget once its capability planned `planned_steps` in all from the state it met: the
/// budget that plan's length would have had at dispatch, when that is more than `budget`, within the
/// `remaining_at_start` steps the episode had then. The plan counts each stage as planned at its entry, not
/// the time it took, so the budget follows a longer path and never a stalled one.
std::uint32_t raised_budget(std::uint32_t budget, std::uint32_t planned_steps,
                            std::uint32_t remaining_at_start);

}  // namespace dh::gov
