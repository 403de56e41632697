// What every capability's skill is to its host process: grounding at the capability (check, before any
// motion), start, then one 7-d action per observation until it completes or fails with a reason.
// Pure logic without DDS, so a skill runs the same in its process and in an in-process test.
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dh/common/command.hpp"
#include "dh/common/observation.hpp"

namespace dh::cap {

using Bindings = std::vector<std::pair<std::string, std::string>>;  ///< role -> entity or symbol
using Theta = std::map<std::string, double>;                         ///< revisable parameters θ

enum class SkillStatus { Running, Completed, Failed };

struct SkillStep {
  SkillStatus status = SkillStatus::Running;
  std::array<double, 7> action{};
  std::string stage;
  std::string reason;
  double progress = 0;
  /// The steps the skill's plan needs in all, as it stands: its stages entered, as long as each was planned
  /// at its entry (a path over something tall is longer than θ says), and θ's steps for those not begun.
  /// 0: its cost_steps(). It grows only when a stage is planned longer than θ, never with time spent.
  int planned_steps = 0;
  FailureCode failure = FailureCode::None;  ///< set with Failed
};

/// `s` (its stage and progress so far) turned into the step that ends the skill with a failure.
inline SkillStep failed(SkillStep s, FailureCode code, std::string reason) {
  s.status = SkillStatus::Failed;
  s.failure = code;
  s.reason = std::move(reason);
  return s;
}

/// The step that ends a skill with success.
inline SkillStep completed_step() {
  SkillStep s;
  s.status = SkillStatus::Completed;
  s.stage = "done";
  s.progress = 1;
  return s;
}

/// A duration parameter θ (steps, stored as a double) as a step count of at least 1.
inline int steps(double v) { return v < 1.5 ? 1 : static_cast<int>(v + 0.5); }

/// A tool pose the host recorded earlier in the episode (keyframe recovery returns to one).
struct Keyframe {
  std::uint32_t step = 0;
  std::array<double, 3> p{};
  std::array<double, 4> q{1, 0, 0, 0};
};

/// What a skill may know beyond the observation: the episode's keyframes, oldest first.
struct SkillContext {
  std::vector<Keyframe> keyframes;
};

class Skill {
 public:
  virtual ~Skill() = default;
  /// The refusal reason when the command cannot start or cannot be completed within `budget_steps`
  /// (entities absent, geometry the hand cannot serve, budget short); nullopt when it can start.
  virtual std::optional<std::string> check(const Bindings& args, const Observation& obs,
                                           int budget_steps) const = 0;
  /// Plans from the observation; call check() first.
  virtual void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) = 0;
  /// The action for this observation; the status says when the command ended.
  virtual SkillStep next(const Observation& obs) = 0;
  /// Cost model: the steps one nominal execution needs.
  virtual int cost_steps() const = 0;
};

/// One capability a family process serves: its name and how to build its skill from θ (throws
/// std::invalid_argument naming an unknown parameter).
struct CapabilityDef {
  std::string name;
  std::function<std::unique_ptr<Skill>(const Theta&)> make;
  /// What the skill runs beyond its θ, part of its announced version and so of each grounding's record:
  /// vla_act's policy ("embedded mlp-<weights checksum>"); empty for the analytic skills.
  std::string runs{};
  /// The longest one step of the skill may block its host's event loop (a policy server's request bound);
  /// the host keeps its liveliness through that much, and not longer.
  std::chrono::milliseconds blocks_up_to{};
};

/// The entity (or symbol) bound to `role`, or "" when absent.
std::string arg(const Bindings& args, const std::string& role);

/// A skill's named parameters θ, pointing at its Params struct, which has no defaults: load() sets them all.
class ParamTable {
 public:
  ParamTable(std::string capability, std::initializer_list<std::pair<const char*, double*>> fields);
  /// Sets every field from `theta`; throws std::invalid_argument naming an unknown key or the missing ones.
  void load(const Theta& theta) const;

 private:
  std::string capability_;
  std::vector<std::pair<std::string, double*>> fields_;
};

}  // namespace dh::cap
