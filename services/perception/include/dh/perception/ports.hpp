// The perception service's ports: what its DDS shell (node/perception_node.cpp) reads and writes around
// the masks and estimates of this library. README.md lists them; a test checks the list.
#pragma once

#include "dh/common/ports.hpp"

namespace dh::perception {

const Ports& ports();

}  // namespace dh::perception
