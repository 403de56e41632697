// The planner-error perturbation applied to an advice (common/planner_errors.hpp): the backend's advice is
// made wrong in the way drawn for this request, where that way applies.
#pragma once

#include "dh/common/planner_errors.hpp"
#include "dh/planner/rules.hpp"

namespace dh::planner {

/// Makes `a` (the backend's advice to `ctx`) wrong as `draw` says and returns the error made:
///   WrongCapability: another eligible capability (not vla_act), the same arguments;
///   WrongArgument: one argument's entity replaced by another entity of the scene;
///   DroppedStep: the plan's next step advised instead (none when the advice has no later step);
///   RepeatedStep: the last step of the rules' plan already completed advised again (none when no step
///   has completed, or the instruction does not parse).
/// A refusal, or an error with no candidate, is left as it is and returns None.
PlannerError make_wrong(PlannerAdvice& a, const PlanContext& ctx, const PlannerErrorDraw& draw);

}  // namespace dh::planner
