// Plain-data views of the messages the governor reads and writes (the node converts to/from DDS).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/command.hpp"
#include "dh/common/perceived_world.hpp"
#include "dh/common/planner_errors.hpp"
#include "dh/common/planner_refusal.hpp"
#include "dh/common/robot_contract.hpp"

namespace dh::gov {

using Bindings = std::vector<std::pair<std::string, std::string>>;  ///< role -> entity, in order

struct PlanStep {
  std::string capability;
  Bindings args;
};

struct Advice {
  std::string request_id;
  bool refused = false;
  std::string capability;
  Bindings args;
  std::string rationale, reason, backend;
  bool done = false;            ///< the planner judges every step completed
  std::vector<PlanStep> rest;   ///< the plan's later steps (seq runs them in order)
  PlannerError injected = PlannerError::None;  ///< the error the planner made on purpose
  PlannerRefusal why = PlannerRefusal::None;   ///< set with refused
};

struct CapabilityInfo {
  std::string capability, instance, version;
  std::vector<std::string> arguments;       ///< roles it needs
  std::vector<std::string> preconditions;   ///< e.g. "gripper_empty", "object_graspable"
  std::map<std::string, double> parameters; ///< revisable θ
  std::uint32_t cost_steps = 0;
  std::uint64_t started_ns = 0;
  bool alive = true;
  bool draining = false;  ///< announced draining: its running commands go on, new ones go elsewhere
};

struct Command {
  std::string command_id, capability, instance;
  std::string version{};  ///< the instance's announced version (for vla_act, its policy's weights): recorded
  Bindings args;
  std::map<std::string, double> theta;
  std::uint32_t start_step = 0, budget_steps = 0, lease_until_step = 0;
  std::uint32_t decision_period = robot::kDecisionPeriodSteps;  ///< the episode's; progress comes at least this often
  std::optional<PerceptionLimits> perception{};  ///< set: grounded in perception with the episode's limits
};

struct Lease {
  std::string command_id;
  std::uint32_t valid_until_step = 0, budget_until_step = 0;
  bool revoked = false;
};

using dh::CommandState;
using dh::to_string;

struct CommandStatus {
  std::string command_id, instance;
  CommandState state = CommandState::Running;
  std::string reason, stage;
  std::uint32_t step = 0, steps_used = 0;
  double progress = 0;
  FailureCode failure = FailureCode::None;
  /// The steps the capability's plan needs in all, as it stands (0: not said): a plan longer than the cost
  /// model raises the command's budget (raised_budget).
  std::uint32_t planned_steps = 0;
};

}  // namespace dh::gov
