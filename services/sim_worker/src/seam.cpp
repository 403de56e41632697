#include "dh/sim/seam.hpp"

namespace dh::sim {

AdmissionResult admit_action(const std::string& command_id, std::uint32_t action_step,
                             std::uint32_t current_step, std::uint32_t episode_budget,
                             const LeaseState& lease, bool grace_elapsed) {
  const std::string at = " (action step " + std::to_string(action_step) + ")";
  if (action_step != current_step)
    return {Admission::RejectStep,
            "channel is at step " + std::to_string(current_step) + ", not " + std::to_string(action_step)};
  if (current_step >= episode_budget)
    return {Admission::RejectBudget,
            "episode budget of " + std::to_string(episode_budget) + " steps is spent" + at};
  if (!lease.known || lease.command_id != command_id) {
    if (!grace_elapsed) return {Admission::WaitForLease, ""};
    return {Admission::RejectCommand, "no lease granted to command '" + command_id + "'" + at};
  }
  if (lease.revoked) return {Admission::RejectLease, "lease of '" + command_id + "' was revoked" + at};
  if (action_step >= lease.budget_until_step)
    return {Admission::RejectBudget, "command budget of '" + command_id + "' ends at step " +
                                         std::to_string(lease.budget_until_step) + at};
  if (action_step >= lease.valid_until_step)
    return {Admission::WaitForLease, "lease of '" + command_id + "' expired at step " +
                                         std::to_string(lease.valid_until_step) + "; held until it is renewed"};
  if (lease.writer_silent)
    return {Admission::WaitForLease, "lease writer missed its deadline; held until it is heard again"};
  return {Admission::Apply, ""};
}

const char* admission_name(Admission a) {
  switch (a) {
    case Admission::Apply: return "apply";
    case Admission::WaitForLease: return "wait_for_lease";
    case Admission::RejectStep: return "rejected_step";
    case Admission::RejectBudget: return "rejected_budget";
    case Admission::RejectLease: return "rejected_lease";
    case Admission::RejectCommand: return "rejected_command";
  }
  return "?";
}

SeamEventKind seam_event_kind(Admission a) {
  switch (a) {
    case Admission::RejectBudget: return SeamEventKind::RejectedBudget;
    case Admission::RejectLease: return SeamEventKind::RejectedLease;
    case Admission::RejectCommand: return SeamEventKind::RejectedCommand;
    default: return SeamEventKind::RejectedStep;
  }
}

}  // namespace dh::sim
