#include "dh/common/command.hpp"

namespace dh {

const char* to_string(CommandState s) {
  switch (s) {
    case CommandState::Accepted:
      return "accepted";
    case CommandState::Refused:
      return "refused";
    case CommandState::Running:
      return "running";
    case CommandState::Completed:
      return "completed";
    case CommandState::Failed:
      return "failed";
    case CommandState::Expired:
      return "expired";
    case CommandState::Cancelled:
      return "cancelled";
  }
  return "?";
}

const char* to_string(Outcome o) {
  switch (o) {
    case Outcome::Success:
      return "success";
    case Outcome::BudgetExhausted:
      return "budget_exhausted";
    case Outcome::GaveUp:
      return "gave_up";
    case Outcome::Infrastructure:
      return "infrastructure";
    case Outcome::Rejected:
      return "rejected";
  }
  return "?";
}

const char* to_string(FailureCode c) {
  switch (c) {
    case FailureCode::None:
      return "none";
    case FailureCode::EntityLost:
      return "entity_lost";
    case FailureCode::GraspMissed:
      return "grasp_missed";
    case FailureCode::GraspSlipped:
      return "grasp_slipped";
    case FailureCode::ObjectDropped:
      return "object_dropped";
    case FailureCode::HandleMissed:
      return "handle_missed";
    case FailureCode::HandleLost:
      return "handle_lost";
    case FailureCode::StateNotReached:
      return "state_not_reached";
    case FailureCode::PushExhausted:
      return "push_exhausted";
    case FailureCode::ContactLost:
      return "contact_lost";
    case FailureCode::PolicyNotReady:
      return "policy_not_ready";
    case FailureCode::PolicyError:
      return "policy_error";
    case FailureCode::PerceptionLost:
      return "perception_lost";
  }
  return "?";
}

}  // namespace dh
