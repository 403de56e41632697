// What the robot seam refused or corrected: one code per kind, the same values in the same order as
// idl/robot.idl SeamEventKind, and one name per code for the evidence (over DDS and in process alike).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace dh {

enum class SeamEventKind {
  RejectedLease,
  RejectedBudget,
  RejectedCommand,
  RejectedStep,
  SafetyHold,
  WorkspaceClamp,
  ActionClamped,
  RejectedChannel,  ///< an action or lease for a channel no simulator worker serves
  SpeedLimited,     ///< the arm controller braked a joint above its limit (docs/controller.md)
  Ended,            ///< the seam ended the episode: its cell failed, or nothing advanced it
};

inline const char* to_string(SeamEventKind k) {
  static const char* names[] = {"rejected_lease", "rejected_budget", "rejected_command", "rejected_step",
                                "safety_hold",    "workspace_clamp", "action_clamped",   "rejected_channel",
                                "speed_limited",  "seam_ended"};
  const auto i = static_cast<std::size_t>(k);
  return i < std::size(names) ? names[i] : "unknown_kind";
}

/// Whether the seam refused an action (the rest are corrections, holds and the episode's end).
inline bool is_refusal(SeamEventKind k) {
  return k == SeamEventKind::RejectedLease || k == SeamEventKind::RejectedBudget ||
         k == SeamEventKind::RejectedCommand || k == SeamEventKind::RejectedStep ||
         k == SeamEventKind::RejectedChannel;
}

struct SeamEvent {
  std::uint32_t step = 0;
  std::string command_id;
  SeamEventKind kind = SeamEventKind::RejectedStep;
  std::string reason;
  std::string episode_id;  ///< the episode the refused action named, when it is not the channel's own
};

}  // namespace dh
