// vla_act: a learned policy as one more capability. It is handed an instruction (the episode's, when the
// fast brain hands it a segment or the bare arm hands it the episode), asks its action source for a chunk
// of actions, executes `execute_steps` of them and asks again. A policy has no model of its own
// progress or termination: it runs until the governor's lease or budget ends it, or the verdict latches;
// it reports 1 − exp(−steps / cost) as progress, which always grows, so stagnation never fires on it.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/cap/skill.hpp"
#include "dh/policy/model.hpp"

namespace dh::cap {

/// An action source that cannot answer yet (its camera images have not arrived): the skill holds the
/// hand still for that step and fails only when it stays so for `max_wait_steps`.
struct SourceNotReady : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Where vla_act's actions come from: the embedded MLP, or a policy server.
class ActionSource {
 public:
  virtual ~ActionSource() = default;
  /// The next actions (at least one) for this observation and instruction, given the gripper action
  /// applied last; throws std::runtime_error with the reason when none can be had (the skill then fails).
  virtual std::vector<policy::Action> chunk(const Observation& obs, const std::string& instruction,
                                            double gripper_command) = 0;
  virtual std::string describe() const = 0;
  /// The longest chunk() may take (it runs on the capability host's event loop).
  virtual std::chrono::milliseconds longest_call() const { return {}; }
};

/// The frozen embedded policy of a weight file.
class EmbeddedPolicy : public ActionSource {
 public:
  explicit EmbeddedPolicy(policy::PolicyModel model) : model_(std::move(model)) {}
  std::vector<policy::Action> chunk(const Observation& obs, const std::string& instruction,
                                    double gripper_command) override {
    return model_.act(obs, instruction, gripper_command);
  }
  std::string describe() const override { return "embedded " + model_.version(); }

 private:
  policy::PolicyModel model_;
};

struct VlaActParams {
  double execute_steps;  ///< actions of each chunk executed before the policy is asked again
  /// > 0: temporal ensembling instead: the policy is asked every step and each action is the mean of
  /// every chunk's prediction for this step, weighted exp(-ensemble_decay · age in steps).
  double ensemble_decay;
  double cost_steps;      ///< the segment a hand-over nominally takes (budget ⌈1.5·cost⌉+10)
  double max_wait_steps;  ///< steps the hand may hold still waiting for a source that is not ready
  ParamTable table();
};

class VlaActSkill : public Skill {
 public:
  VlaActSkill(std::shared_ptr<ActionSource> source, const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  SkillStep next(const Observation& obs) override;
  int cost_steps() const override;

 private:
  std::shared_ptr<ActionSource> source_;
  VlaActParams p_;
  std::string instruction_;
  std::vector<policy::Action> chunk_;
  std::vector<std::pair<int, std::vector<policy::Action>>> recent_;  ///< (step asked, chunk), ensembling
  std::size_t next_ = 0;
  int used_ = 0, waited_ = 0;
  double gripper_command_ = -1;
};

/// The vla_act capability over `source`.
CapabilityDef vla_act_def(std::shared_ptr<ActionSource> source);

}  // namespace dh::cap
