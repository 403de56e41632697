// The clause reader: an instruction's words -> plan steps, clause by clause, keeping track of what has been
// mentioned so that "it", "them", "the drawer" and "the other one" find their referents.
#pragma once

#include <string>
#include <vector>

#include "dh/planner/rules.hpp"

namespace dh::planner {

/// Throws std::invalid_argument naming the words it could not place.
std::vector<PlanStep> read_instruction(const std::string& instruction, const std::vector<EntityState>& scene);

/// A lone noun phrase resolved against the scene (rules.hpp's resolve()); throws like read_instruction.
std::vector<std::string> read_noun_phrase(const std::string& phrase, const std::vector<EntityState>& scene);

}  // namespace dh::planner
