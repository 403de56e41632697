// The governor service's ports: what its DDS shell (node/governor_node.cpp) reads and writes for the
// episode machines it runs, one per channel. README.md lists them; a test checks the list.
#pragma once

#include "dh/common/ports.hpp"

namespace dh::gov {

const Ports& ports();

}  // namespace dh::gov
