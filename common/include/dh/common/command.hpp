// What a capability reports about a command it was given: one state machine shared by the governor, the
// capability host and the evidence (idl/command.idl CommandState has the same values in the same order).
#pragma once

namespace dh {

enum class CommandState { Accepted, Refused, Running, Completed, Failed, Expired, Cancelled };

const char* to_string(CommandState s);

/// Why a capability's command failed, typed (idl/command.idl FailureCode: the same values in the same
/// order). The governor chooses a recovery by it; the reason beside it is for people and may be reworded.
enum class FailureCode {
  None,
  EntityLost,       ///< an entity the command is bound to left the observation
  GraspMissed,      ///< the jaw closed on nothing
  GraspSlipped,     ///< the object did not rise with the tool
  ObjectDropped,    ///< the object fell from the jaw while carried
  HandleMissed,     ///< the jaw closed on nothing at a part's handle
  HandleLost,       ///< the jaw lost the handle while moving the part
  StateNotReached,  ///< the part's motion ended short of the asked state
  PushExhausted,    ///< the push ran out of its steps before the object reached the target
  ContactLost,      ///< the object slid off the pusher
  PolicyNotReady,   ///< the learned policy gave no actions for too long
  PolicyError,      ///< the learned policy failed or returned nothing
  PerceptionLost,   ///< perception could not show what the command is bound to
};

const char* to_string(FailureCode c);

/// How an episode ended, typed (idl/episode.idl Outcome: the same values in the same order). The campaign
/// counts losses by it; the reason beside it is for people.
enum class Outcome {
  Success,
  BudgetExhausted,  ///< the episode's budget ran out
  GaveUp,           ///< the governor ended it (no progress, nothing left to try, the planner said done)
  Infrastructure,   ///< a process, the simulator or a deadline failed: not the agent's failure
  Rejected,         ///< the governor refused the request itself (unknown arm, busy channel)
};

const char* to_string(Outcome o);
/// Not the agent's failure: infrastructure or a rejected request.
inline bool lost_to_infrastructure(Outcome o) { return o == Outcome::Infrastructure || o == Outcome::Rejected; }

/// Whether the command is over (every state but accepted and running).
inline bool ended(CommandState s) { return s != CommandState::Accepted && s != CommandState::Running; }

}  // namespace dh
