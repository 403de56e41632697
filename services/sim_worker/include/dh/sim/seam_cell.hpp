// What the seam (seam_core.hpp) drives: one robot cell, stepped at the control rate. The simulator's
// MuJoCo workcell is one; a robot adapter's arm behind its controller is another. The seam owns admission,
// holds and the evidence; the cell owns the physics or the metal, and the corrections it made on the way.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"

namespace dh::sim {

/// A correction the cell made to one step's action, or a hold it imposed.
struct StepEvent {
  enum Kind { SafetyHold, WorkspaceClamp, ActionClamped, SpeedLimited } kind;
  std::string reason;
};

inline SeamEventKind seam_event_kind(StepEvent::Kind k) {
  return k == StepEvent::SafetyHold       ? SeamEventKind::SafetyHold
         : k == StepEvent::WorkspaceClamp ? SeamEventKind::WorkspaceClamp
         : k == StepEvent::SpeedLimited   ? SeamEventKind::SpeedLimited
                                          : SeamEventKind::ActionClamped;
}

/// A cell whose whole state can be recorded, digested and put back: what makes evidence replay. A
/// simulated cell is one; a real arm is not.
class RecordableState {
 public:
  virtual ~RecordableState() = default;
  virtual std::uint64_t model_hash() const = 0;
  virtual std::uint32_t engine_version() const = 0;  ///< the physics engine's (MuJoCo's mj_version())
  virtual StateShape shape() const = 0;
  /// The state the last step ended with (state_log.hpp).
  virtual const PhysicsState& physics_state() const = 0;
  virtual StateDigest digest() const = 0;
  /// Puts a recorded state back; stepping on is then bit-identical to the recording.
  virtual void restore(const PhysicsState& s) = 0;
};

class SeamCell {
 public:
  virtual ~SeamCell() = default;
  /// Applies one 7-d action (dh/common/robot_contract.hpp) for one control step; returns the corrections.
  /// Throws std::runtime_error when the cell cannot go on (the physics failed, the arm was stopped): the
  /// seam ends the episode with its message.
  virtual std::vector<StepEvent> step(const std::array<double, 7>& action) = 0;
  /// The observation after the last step (step and budget fields are the seam's to fill).
  virtual Observation observe() const = 0;
  /// The cell's state as evidence, or null where it cannot be recorded (a real arm).
  virtual RecordableState* recordable() { return nullptr; }
};

}  // namespace dh::sim
