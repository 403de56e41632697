// What a command should leave holding: its effect, stated as the benchmark's goal predicates over the
// command's arguments, so a probe can say whether a re-run command did what it was for.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "dh/common/suite.hpp"

namespace dh::evo {

/// The effect of a command with `args` (role -> entity) in a task whose goal is `goal`:
///   a `state` argument (open|closed|on|off) -> Open/Close/TurnOn/TurnOff of the other argument;
///   `object` and `target` -> the goal's term over exactly those two (On or In), else its term over the
///   object and a site of the target ("stove" -> stove_cook_region), else On(object, target).
/// Empty when the arguments name no effect (a recovery, `vla_act`): then the command's effect is its
/// completion.
std::vector<PredicateSpec> command_effect(const std::vector<std::pair<std::string, std::string>>& args,
                                          const std::vector<PredicateSpec>& goal);

}  // namespace dh::evo
