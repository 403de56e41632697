// Conversions between generated DDS types and the plain structs logic libraries use.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dh/common/command.hpp"
#include "dh/common/goal.hpp"
#include "dh/common/observation.hpp"
#include "dh/common/perceived_world.hpp"
#include "dh/common/planner_errors.hpp"
#include "dh/common/planner_refusal.hpp"
#include "dh/msg/episode.h"
#include "dh/msg/perception.h"
#include "dh/msg/robot.h"
#include "dh/msg/types.h"

namespace dh::convert {

std::vector<EntityState> from_msg(const std::vector<msg::EntityPose>& entities);
std::vector<msg::EntityPose> to_msg(const std::vector<EntityState>& entities);
Observation from_msg(const msg::Observation& m);
msg::Observation to_msg(const Observation& o, std::uint32_t channel, const std::string& episode_id);

std::vector<std::pair<std::string, std::string>> from_msg(const std::vector<msg::Binding>& b);
std::vector<msg::Binding> to_msg(const std::vector<std::pair<std::string, std::string>>& b);

/// Box centres become bottom centres (EntityState::p); sizes become half extents.
SceneEstimate from_msg(const msg::SceneEstimate& m);

PerceptionLimits from_msg(const msg::PerceptionLimits& m);
/// An outcome code from another process; a value this build does not know is counted as infrastructure
/// (a mismatched peer), never as the agent's failure.
Outcome from_msg(msg::Outcome o);
msg::PerceptionLimits to_msg(const PerceptionLimits& l);

PlannerErrorRates from_msg(const msg::PlannerErrorRates& m);
msg::PlannerErrorRates to_msg(const PlannerErrorRates& r);
std::vector<GoalTerm> from_msg(const std::vector<msg::GoalTerm>& m);
std::vector<msg::GoalTerm> to_msg(const std::vector<GoalTerm>& goal);
/// A verifier code this build does not know reads as none (the governor refuses the episode, naming it).
std::optional<Verifier> from_msg(msg::Verifier v);
msg::Verifier to_msg(Verifier v);

/// An error code this build does not know reads as none: the advice is taken as the planner gave it.
PlannerError from_msg(msg::PlannerError e);
msg::PlannerError to_msg(PlannerError e);
PlannerRefusal from_msg(msg::PlannerRefusal r);
msg::PlannerRefusal to_msg(PlannerRefusal r);

std::map<std::string, double> from_msg(const std::vector<msg::Param>& p);
std::vector<msg::Param> to_msg(const std::map<std::string, double>& p);

}  // namespace dh::convert
