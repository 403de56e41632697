#include "dh/planner/errors.hpp"

#include <algorithm>
#include <cmath>

#include "dh/common/history.hpp"

namespace dh::planner {
namespace {

/// One of `n` candidates by the draw's pick in [0, 1).
std::size_t choose(double pick, std::size_t n) { return std::min(n - 1, static_cast<std::size_t>(pick * n)); }

}  // namespace

PlannerError make_wrong(PlannerAdvice& a, const PlanContext& ctx, const PlannerErrorDraw& draw) {
  if (a.refused || a.done || draw.error == PlannerError::None) return PlannerError::None;
  const std::string note = std::string(" [planner error: ") + to_string(draw.error) + "]";
  switch (draw.error) {
    case PlannerError::WrongCapability: {
      std::vector<std::string> others;
      for (const auto& c : ctx.capabilities)
        if (c != a.capability && c != "vla_act") others.push_back(c);
      if (others.empty()) return PlannerError::None;
      a.capability = others[choose(draw.pick, others.size())];
      break;
    }
    case PlannerError::WrongArgument: {
      std::vector<std::size_t> entity_args;  // arguments that name an entity (not a state or an instruction)
      for (std::size_t i = 0; i < a.args.size(); ++i)
        for (const auto& e : ctx.scene)
          if (e.name == a.args[i].second) entity_args.push_back(i);
      std::vector<std::string> others;
      for (const auto& e : ctx.scene)
        if (std::none_of(a.args.begin(), a.args.end(), [&](const auto& b) { return b.second == e.name; }))
          others.push_back(e.name);
      if (entity_args.empty() || others.empty()) return PlannerError::None;
      // One pick chooses both: which argument, then which entity.
      const double scaled = draw.pick * entity_args.size();
      const std::size_t which = entity_args[choose(draw.pick, entity_args.size())];
      a.args[which].second = others[choose(scaled - std::floor(scaled), others.size())];
      break;
    }
    case PlannerError::DroppedStep:
      if (a.rest.empty()) return PlannerError::None;
      a.capability = a.rest.front().capability;
      a.args = a.rest.front().args;
      a.rest.erase(a.rest.begin());
      break;
    case PlannerError::RepeatedStep: {
      std::vector<PlanStep> steps;
      try {
        steps = plan_steps(ctx.instruction, ctx.scene);
      } catch (const std::invalid_argument&) {
        return PlannerError::None;
      }
      const PlanStep* last = nullptr;
      for (const auto& s : steps)
        if (history::completed(ctx.history, s.args)) last = &s;
      if (!last) return PlannerError::None;
      a.rest.insert(a.rest.begin(), PlanStep{a.capability, a.args});
      a.capability = last->capability;
      a.args = last->args;
      break;
    }
    case PlannerError::None: break;
  }
  a.rationale += note;
  return draw.error;
}

}  // namespace dh::planner
