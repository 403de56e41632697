#include "dh/planner/rules.hpp"

#include <algorithm>
#include <stdexcept>

#include "clauses.hpp"
#include "dh/common/history.hpp"

namespace dh::planner {

namespace {

PlannerAdvice refusal(std::string why) {
  PlannerAdvice a;
  a.refused = true;
  a.why = PlannerRefusal::Planning;
  a.reason = std::move(why);
  return a;
}

bool eligible(const PlanContext& ctx, const std::string& cap) {
  return std::find(ctx.capabilities.begin(), ctx.capabilities.end(), cap) != ctx.capabilities.end();
}

}  // namespace

std::vector<std::string> resolve(const std::string& phrase, const std::vector<EntityState>& scene) {
  try {
    return read_noun_phrase(phrase, scene);
  } catch (const std::invalid_argument&) {
    return {};
  }
}

std::vector<PlanStep> plan_steps(const std::string& instruction, const std::vector<EntityState>& scene) {
  return read_instruction(instruction, scene);
}

PlannerAdvice plan_rules(const PlanContext& ctx) {
  std::vector<PlanStep> steps;
  try {
    steps = plan_steps(ctx.instruction, ctx.scene);
  } catch (const std::invalid_argument& e) {
    return refusal(e.what());
  }
  std::vector<PlanStep> open;
  for (const auto& s : steps)
    if (!history::completed(ctx.history, s.args)) open.push_back(s);
  if (open.empty()) {
    PlannerAdvice a = refusal("every step of the plan completed");
    a.done = true;
    return a;
  }
  PlannerAdvice a;
  a.capability = open.front().capability;
  a.args = open.front().args;
  if (!eligible(ctx, a.capability)) {
    if (!eligible(ctx, "vla_act"))
      return refusal(a.capability + " is needed for step " + history::signature(a.args) +
                     " but no eligible capability provides it");
    // No analytic route: the learned policy is handed the instruction (it was trained on whole ones).
    a.rationale = a.capability + " is not eligible for step " + history::signature(a.args) +
                  ": hand the instruction to vla_act";
    a.capability = "vla_act";
    a.args = {{"instruction", ctx.instruction}};
    return a;
  }
  a.rationale = "step " + std::to_string(steps.size() - open.size() + 1) + " of " + std::to_string(steps.size()) +
                ": " + a.capability + " " + history::signature(a.args);
  a.rest.assign(open.begin() + 1, open.end());
  return a;
}

}  // namespace dh::planner
