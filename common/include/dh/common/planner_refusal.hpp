// Why the slow brain's advice is a refusal, typed from the planner to the governor's evidence, so that
// attribution (issue 16) tells a planner that could not be reached or read (layer 3) from one that could
// not plan (layer 4) without reading its reason's words.
#pragma once

#include <cstdint>

namespace dh {

/// idl PlannerRefusal: the same values in the same order.
enum class PlannerRefusal : std::uint8_t {
  None,         ///< not a refusal
  Planning,     ///< it read the request and gave no step: it cannot plan it, or every step is done
  Unavailable,  ///< the model server: no key, no connection, no reply in time, an HTTP error
  Malformed,    ///< a reply that cannot be read as an advisory (not JSON, the schema broken), repair included
};

}  // namespace dh
