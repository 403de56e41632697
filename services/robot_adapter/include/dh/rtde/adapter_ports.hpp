// The robot adapter's ports: the seam core's (SeamCore::ports()) and the channel it announces. Its seam
// gives no verdict of its own: a real cell has no benchmark oracle (the Verdict port stays silent).
#pragma once

#include "dh/common/ports.hpp"

namespace dh::rtde {

const Ports& adapter_ports();

}  // namespace dh::rtde
