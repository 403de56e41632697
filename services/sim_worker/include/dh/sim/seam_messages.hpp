// The seam core's inputs from, and events to, DDS messages: one conversion for both shells that run a
// seam core (sim_worker's lanes and robot_adapter).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "dh/common/seam_event.hpp"
#include "dh/msg/command.h"
#include "dh/msg/robot.h"
#include "dh/sim/seam_core.hpp"

namespace dh::sim {

inline LeaseGrant from_msg(const msg::Lease& l) {
  return {l.episode_id(), l.command_id(), l.valid_until_step(), l.budget_until_step(), l.revoked()};
}

inline ActionIn from_msg(const msg::Action& a) {
  ActionIn in{a.episode_id(), a.command_id(), a.step(), {}, a.frames()};
  std::copy_n(a.a().begin(), in.a.size(), in.a.begin());
  return in;
}

/// `e` on `channel`; an event that names no episode belongs to `episode`.
inline msg::SeamEvent to_msg(const SeamEvent& e, std::uint32_t channel, const std::string& episode) {
  msg::SeamEvent m;
  m.channel(channel);
  m.episode_id(e.episode_id.empty() ? episode : e.episode_id);
  m.step(e.step);
  m.command_id(e.command_id);
  m.kind(static_cast<msg::SeamEventKind>(e.kind));
  m.reason(e.reason);
  return m;
}

}  // namespace dh::sim
