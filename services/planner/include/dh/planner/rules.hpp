// The `rules` slow-brain backend: deterministic parsing of an English instruction against the scene
// snapshot (src/lexicon.cpp: the words; src/clauses.cpp: clauses, coordination and coreference;
// src/reference.cpp: noun phrases -> entities by category, colour, position, state, owner and relation).
// It advises the first step whose arguments have not completed yet, with the rest of the plan behind it. It
// names the capability the instruction asks for (a push for "push") and leaves feasibility to the fast
// brain. It never gives poses; what it cannot form is a refusal naming the words it could not place.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "dh/common/observation.hpp"
#include "dh/common/planner_refusal.hpp"

namespace dh::planner {

using Args = std::vector<std::pair<std::string, std::string>>;

struct PlanContext {
  std::string instruction;
  std::vector<EntityState> scene;         ///< entity names, kinds, positions, part joint values
  std::vector<std::string> capabilities;  ///< eligible capabilities
  std::vector<std::string> history;       ///< dh::history lines
};

/// Capability -> its argument roles as the capability announces them ("object", "state:open|closed").
using CapabilityRoles = std::map<std::string, std::vector<std::string>>;

struct PlanStep {
  std::string capability;
  Args args;
};

struct PlannerAdvice {
  bool refused = false;
  PlannerRefusal why = PlannerRefusal::None;  ///< set with refused
  bool done = false;            ///< every step of the plan completed (a refusal that says so)
  std::string capability;
  Args args;
  std::string rationale, reason;
  std::vector<PlanStep> rest;   ///< the plan's later steps, in order
};

PlannerAdvice plan_rules(const PlanContext& ctx);

/// The whole plan for an instruction in a scene; throws std::invalid_argument with the reason when a
/// clause cannot be formed.
std::vector<PlanStep> plan_steps(const std::string& instruction, const std::vector<EntityState>& scene);

/// Finds the scene entities a noun phrase names, by their attributes ("the black bowl" -> bowl, "the top
/// drawer" -> cabinet_top_drawer, "the top of the cabinet" -> cabinet_top_side, "the back compartment of
/// the caddy" -> caddy_back_contain_region, "both moka pots" -> both); sides and ordinals pick among
/// otherwise equal candidates by position. Empty when none matches or the match is ambiguous.
std::vector<std::string> resolve(const std::string& phrase, const std::vector<EntityState>& scene);

}  // namespace dh::planner
