#include "dh/gov/grounding.hpp"

#include <algorithm>
#include <cmath>

namespace dh::gov {

std::uint32_t command_budget(std::uint32_t cost_steps, std::uint32_t remaining_steps) {
  const std::uint32_t b = (cost_steps * 3 + 1) / 2 + 10;  // ceil(cost × 1.5) + 10, in integers
  return std::min(b, remaining_steps);
}

std::uint32_t raised_budget(std::uint32_t budget, std::uint32_t planned_steps,
                            std::uint32_t remaining_at_start) {
  if (!planned_steps) return budget;  // the plan's length not said
  return std::max(budget, command_budget(planned_steps, remaining_at_start));
}

namespace {
GroundingResult refuse(Refusal r, std::string why) { return {std::nullopt, r, std::move(why)}; }

const std::string* arg(const Advice& a, const std::string& role) {
  for (const auto& [r, e] : a.args)
    if (r == role) return &e;
  return nullptr;
}

// Declared preconditions the governor can check from the observation alone.
std::optional<std::string> precondition_fails(const std::string& pre, const Advice& a, const Observation& obs) {
  if (pre == "gripper_empty") {
    if (!obs.holding()) return std::nullopt;
    // Holding the command's own object (a regrasp took it) is fine: the skill goes on from there.
    const std::string* object = arg(a, "object");
    const EntityState* o = object ? obs.entity(*object) : nullptr;
    if (o && obs.in_jaw(*o)) return std::nullopt;
    return std::string("the gripper already holds something");
  }
  if (pre == "distinct_entities") {
    std::set<std::string> seen;
    for (const auto& [role, e] : a.args)
      if (obs.entity(e) && !seen.insert(e).second) return "entity '" + e + "' is given for two roles";
    return std::nullopt;
  }
  if (pre == "task_goal_unmet") {
    // Judged from the benchmark predicate the seam reports, not from the command's own arguments.
    if (obs.goal_holds) return std::string("the task's goal already holds (verdict true); nothing to move");
    return std::nullopt;
  }
  return "precondition '" + pre + "' is not known to the governor";
}
}  // namespace

GroundingResult ground(const GroundingInput& in) {
  const Advice& a = in.advice;
  if (a.refused) {
    if (a.why == PlannerRefusal::Unavailable)
      return refuse(Refusal::PlannerUnavailable, "planner unavailable: " + a.reason);
    if (a.why == PlannerRefusal::Malformed)
      return refuse(Refusal::PlannerMalformed, "planner reply unusable: " + a.reason);
    return refuse(Refusal::PlannerRefused, "planner refused: " + a.reason);
  }
  if (in.masked.count(a.capability))
    return refuse(Refusal::CapabilityMasked, "capability '" + a.capability + "' is switched off in this arm");
  if (!in.registry.known(a.capability))
    return refuse(Refusal::UnknownCapability, "no capability '" + a.capability + "' was ever announced");
  const auto info = in.registry.newest_alive(a.capability);
  if (!info)
    return refuse(Refusal::CapabilityNotAlive,
                  "no instance of '" + a.capability + "' takes commands (each lost its liveliness lease or is draining)");
  // Declared roles: "object" takes a scene entity, "state:open|closed" one of the listed symbols,
  // "instruction:*" any non-empty text.
  for (const auto& decl : info->arguments) {
    const auto colon = decl.find(':');
    const std::string role = decl.substr(0, colon);
    const std::string* value = arg(a, role);
    if (!value) return refuse(Refusal::MissingArgument, "'" + a.capability + "' needs argument '" + role + "'");
    if (colon == std::string::npos) {
      if (!in.obs.entity(*value))
        return refuse(Refusal::UnresolvedEntity, "argument " + role + "='" + *value + "' names no entity in the scene");
      continue;
    }
    if (decl.substr(colon + 1) == "*") {  // free text, e.g. vla_act's instruction
      if (value->empty()) return refuse(Refusal::MissingArgument, "argument " + role + " of '" + a.capability + "' is empty");
      continue;
    }
    const std::string choices = "|" + decl.substr(colon + 1) + "|";
    if (value->empty() || choices.find("|" + *value + "|") == std::string::npos)
      return refuse(Refusal::MissingArgument, "argument " + role + "='" + *value + "' of '" + a.capability +
                                                  "' is not one of " + decl.substr(colon + 1));
  }
  for (const auto& [role, entity] : a.args) {
    const bool declared = std::any_of(info->arguments.begin(), info->arguments.end(), [&](const std::string& d) {
      return d.substr(0, d.find(':')) == role;
    });
    if (!declared)
      return refuse(Refusal::MissingArgument, "'" + a.capability + "' takes no argument '" + role + "'");
  }
  for (const auto& pre : info->preconditions)
    if (auto why = precondition_fails(pre, a, in.obs)) return refuse(Refusal::Precondition, *why);
  // The cost under the θ the command will run with: the library's, else the instance's own.
  const auto library_cost = in.library_costs.find(a.capability);
  const std::uint32_t cost = library_cost != in.library_costs.end() ? library_cost->second : info->cost_steps;
  if (cost > in.remaining_steps)
    return refuse(Refusal::Budget, std::to_string(in.remaining_steps) + " steps remain, '" + a.capability +
                                       "' costs " + std::to_string(cost));
  Command c;
  c.command_id = in.command_id;
  c.capability = a.capability;
  c.instance = info->instance;
  c.version = info->version;
  c.args = a.args;
  const auto theta = in.library.find(a.capability);
  c.theta = theta != in.library.end() ? theta->second : info->parameters;
  c.start_step = in.obs.step;
  c.budget_steps = command_budget(cost, in.remaining_steps);
  const std::uint32_t p = std::max<std::uint32_t>(1, in.decision_period);
  c.lease_until_step = (in.obs.step / p + 1) * p;
  return {c, Refusal::PlannerRefused, ""};
}

}  // namespace dh::gov
