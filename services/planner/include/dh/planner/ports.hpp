// The planner service's ports: what its DDS shell (node/planner_node.cpp) reads and writes around the
// backends (rules.hpp, openai.hpp). README.md lists them; a test checks the list.
#pragma once

#include "dh/common/ports.hpp"

namespace dh::planner {

const Ports& ports();

}  // namespace dh::planner
