#include "dh/rtde/adapter_ports.hpp"

#include "dh/sim/seam_core.hpp"

namespace dh::rtde {

const Ports& adapter_ports() {
  static const Ports p = [] {
    Ports all = sim::SeamCore::ports();
    all.push_back(out_port<port::ChannelStatus>(
        "the arm's channel idle or running, with liveliness, and why its last episode could not go on"));
    return all;
  }();
  return p;
}

}  // namespace dh::rtde
