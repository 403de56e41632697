// The execution contract at the robot seam: whether an action may reach the robot. Pure logic, so it is
// unit-tested without DDS or physics; the sim_worker node (and a hardware adapter) call it.
#pragma once

#include <cstdint>
#include <string>

#include "dh/common/seam_event.hpp"

namespace dh::sim {

/// The lease the governor last granted on a channel.
struct LeaseState {
  bool known = false;
  std::string command_id;
  std::uint32_t valid_until_step = 0;   ///< actions of step t are admitted while t < this
  std::uint32_t budget_until_step = 0;  ///< the command's budget B ends here
  bool revoked = false;
  bool writer_silent = false;  ///< the lease topic missed its DDS deadline: actions hold until it is heard
};

enum class Admission {
  Apply,
  WaitForLease,  ///< hold: expired by step (until renewed), writer silent (until heard), or no lease yet
  RejectStep,    ///< not the step the channel is at (stale or from the future)
  RejectBudget,  ///< the episode's or the command's budget is spent
  RejectLease,   ///< revoked
  RejectCommand, ///< no lease was granted to this command within the grace period
};

struct AdmissionResult {
  Admission decision = Admission::Apply;
  std::string reason;
};

/// Decides on the action of `command_id` for step `action_step` while the channel is at
/// `current_step` with `episode_budget` steps in all. `grace_elapsed`: the action already waited the
/// grace period for a lease of its command. Admission is by step: a lease that is merely late (expired by
/// step, or its writer silent) holds the action, it never refuses it.
AdmissionResult admit_action(const std::string& command_id, std::uint32_t action_step,
                             std::uint32_t current_step, std::uint32_t episode_budget,
                             const LeaseState& lease, bool grace_elapsed);

const char* admission_name(Admission a);

/// The seam event a refusal is recorded as (Apply and WaitForLease are not refusals: RejectedStep).
SeamEventKind seam_event_kind(Admission a);

}  // namespace dh::sim
