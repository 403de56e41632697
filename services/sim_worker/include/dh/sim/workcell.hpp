// One MuJoCo workcell (one channel): physics at 2 ms, control at 20 Hz. An action means what the robot
// contract says (dh/common/robot_contract.hpp), tracked by the scene's controller: robosuite's OSC_POSE
// with a joint-speed limiter under it (osc_pose.hpp, the default, which the skills are tuned to) or the
// joint-space IK used before it (joint_ik.hpp); the 50 Hz safety check runs inside the step.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/joint_ik.hpp"
#include "dh/sim/osc_pose.hpp"
#include "dh/sim/predicates.hpp"
#include "dh/sim/safety.hpp"
#include "dh/sim/seam_cell.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"
#include "dh/sim/scene.hpp"

struct mjModel_;
struct mjData_;

namespace dh::sim {

inline constexpr int kSubsteps = 25;          ///< 20 Hz control over 2 ms physics
inline constexpr int kSafetyEvery = 10;       ///< substeps between safety checks: 50 Hz

class Workcell final : public SeamCell, public RecordableState {
 public:
  /// Compiles the scene's model once; throws ConfigError/runtime_error with MuJoCo's message.
  explicit Workcell(SceneSpec scene);
  ~Workcell();
  Workcell(const Workcell&) = delete;
  Workcell& operator=(const Workcell&) = delete;

  /// Puts the arm at its ready pose, fixtures' parts at their initial positions and the objects where
  /// `seed` places them, lets them settle. Throws std::invalid_argument when a goal predicate names an
  /// unknown entity, region, state or predicate.
  void reset(std::uint64_t seed, const std::vector<PredicateSpec>& goal);
  /// Applies one 7-d action for one control step (50 ms); returns what the seam corrected. Throws
  /// std::runtime_error when MuJoCo's contact or constraint buffer overflowed during the step.
  std::vector<StepEvent> step(const std::array<double, 7>& action) override;
  /// The observation after the last step (step and budget fields are the caller's to fill).
  Observation observe() const override;
  RecordableState* recordable() override { return this; }
  bool goal_holds() const;
  /// Whether another goal holds in the current state (throws like reset() for a goal the scene lacks).
  bool holds(const std::vector<PredicateSpec>& goal) const;
  /// Deepest interpenetration among contacts that involve a scene entity (m, positive = overlap).
  double max_penetration() const;
  /// Fastest linear speed of any free object (m/s).
  double max_object_speed() const;
  const SceneSpec& scene() const { return scene_; }
  const SafetyLimits& limits() const { return limits_; }
  /// The full physics state (state_log.hpp) the last step ended with: what the state log records and
  /// restore() puts back. It is taken before the step's closing mj_forward, which renormalises free
  /// joints' quaternions in qpos (not idempotent in the last bit): restoring it and running mj_forward
  /// again makes the same qpos, derived quantities and warm start as the recorded run had.
  const PhysicsState& physics_state() const override { return ended_; }
  StateShape shape() const override;
  /// Puts a recorded state back (after reset() to the same task, for the goal) and recomputes what
  /// follows from it; stepping on is then bit-identical to the recording. Throws std::invalid_argument
  /// naming both shapes when the state is not of this model.
  void restore(const PhysicsState& s) override;
  /// The physics state in hashes (step_log.hpp): what `dh replay` compares step by step.
  StateDigest digest() const override;
  /// A hash of the compiled model (scene, assets, options): a replay runs on the same model or says so.
  std::uint64_t model_hash() const override { return model_hash_; }
  std::uint32_t engine_version() const override;
  /// The compiled model and its state, read by the camera renderer (camera.hpp).
  const mjModel_* model() const { return m_; }
  const mjData_* data() const { return d_; }

 private:
  struct Ids;
  /// Writes the controller's orientation goal into mjData's userdata (scene.hpp kUserdataSize).
  void store_controller();
  std::array<double, 4> tcp_quat(const mjData_* d) const;
  void capture(PhysicsState& into) const;
  bool in_contact(int body_a, int body_b) const;

  SceneSpec scene_;
  SafetyLimits limits_;
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::unique_ptr<Ids> ids_;
  std::unique_ptr<OscPose> osc_;  ///< one of the two, as the scene says
  std::unique_ptr<JointIk> ik_;
  std::unique_ptr<GoalEvaluator> goal_;      ///< resolved at reset
  std::uint64_t model_hash_ = 0;
  PhysicsState ended_;
};

}  // namespace dh::sim
