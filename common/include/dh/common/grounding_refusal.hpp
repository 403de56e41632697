// Why the governor's grounding G(z, c) refused an advised step, as the evidence records it. The report
// and attribution read the recorded code back with refusal_from_string, so each code is spelled once.
#pragma once

#include <optional>
#include <string_view>

namespace dh {

enum class Refusal {
  PlannerRefused,      ///< the slow brain read the request and gave no step
  PlannerUnavailable,  ///< the slow brain could not be asked: its model server, or no advice in time
  PlannerMalformed,    ///< the slow brain's model answered what cannot be read as an advisory
  UnknownCapability,   ///< never announced
  CapabilityNotAlive,  ///< announced, but its liveliness lapsed
  CapabilityMasked,    ///< switched off by the executor configuration
  MissingArgument,     ///< a role the capability needs is absent, undeclared, or not one of its symbols
  UnresolvedEntity,    ///< an argument names no entity in the scene
  Precondition,        ///< a declared precondition does not hold
  Budget,              ///< remaining steps cannot pay for the cost model
  Perception,          ///< grounding from perception: no fresh estimate, or an argument's entity unseen
};

/// The code the evidence records: planner_refused, unknown_capability, precondition, ...
const char* to_string(Refusal r);

/// The refusal `code` spells (as to_string does); none for any other word.
std::optional<Refusal> refusal_from_string(std::string_view code);

/// The slow brain's own refusals (it refused, could not be asked, or could not be read), not execution's.
bool is_planner(Refusal r);

}  // namespace dh
