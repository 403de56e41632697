// The `rules` slow-brain backend: deterministic parsing of the instruction against the scene's entity
// names. It advises a capability and symbolic arguments, never poses; what it cannot form becomes an
// advisory of refusal with its reason.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace dh::planner {

struct PlanContext {
  std::string instruction;
  std::vector<std::string> entities;      ///< scene entity names
  std::vector<std::string> capabilities;  ///< eligible capabilities
  std::vector<std::string> history;
};

struct PlannerAdvice {
  bool refused = false;
  std::string capability;
  std::vector<std::pair<std::string, std::string>> args;
  std::string rationale, reason;
};

PlannerAdvice plan_rules(const PlanContext& ctx);

/// Finds the scene entity a noun phrase names ("the black bowl" -> "bowl", "wine bottle" ->
/// "wine_bottle"); empty when none or more than one matches.
std::string resolve_entity(const std::string& phrase, const std::vector<std::string>& entities);

}  // namespace dh::planner
