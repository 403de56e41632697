#include "dh/common/grounding_refusal.hpp"

namespace dh {

const char* to_string(Refusal r) {
  switch (r) {
    case Refusal::PlannerRefused: return "planner_refused";
    case Refusal::PlannerUnavailable: return "planner_unavailable";
    case Refusal::PlannerMalformed: return "planner_malformed";
    case Refusal::UnknownCapability: return "unknown_capability";
    case Refusal::CapabilityNotAlive: return "capability_not_alive";
    case Refusal::CapabilityMasked: return "capability_masked";
    case Refusal::MissingArgument: return "missing_argument";
    case Refusal::UnresolvedEntity: return "unresolved_entity";
    case Refusal::Precondition: return "precondition";
    case Refusal::Budget: return "budget";
    case Refusal::Perception: return "perception";
  }
  return "?";
}

std::optional<Refusal> refusal_from_string(std::string_view code) {
  for (int i = 0; i <= static_cast<int>(Refusal::Perception); ++i)
    if (code == to_string(static_cast<Refusal>(i))) return static_cast<Refusal>(i);
  return std::nullopt;
}

bool is_planner(Refusal r) {
  return r == Refusal::PlannerRefused || r == Refusal::PlannerUnavailable || r == Refusal::PlannerMalformed;
}

}  // namespace dh
