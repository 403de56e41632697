// The episode request the process-level tests send by hand: the goal kitchen's "put the bowl on the
// plate" (goal task 8), seed 4, arm full.
#pragma once

#include <cstdint>
#include <string>

#include "dh/msg/episodePubSubTypes.h"

namespace dh::itest {

inline msg::EpisodeRequest bowl_on_plate(std::uint32_t channel, const std::string& id, std::uint32_t budget = 300) {
  msg::EpisodeRequest r;
  r.channel(channel);
  r.episode_id(id);
  r.suite("goal");
  r.task(8);
  r.seed(4);
  r.arm("full");
  r.instruction("put the bowl on the plate");
  r.budget_steps(budget);
  return r;
}

}  // namespace dh::itest
