// The simulator worker's ports: the seam core's (SeamCore::ports()) and those of the process around it,
// which announces its channels and renders cameras. The README's table is checked against this list.
#pragma once

#include "dh/common/ports.hpp"

namespace dh::sim {

const Ports& worker_ports();

}  // namespace dh::sim
