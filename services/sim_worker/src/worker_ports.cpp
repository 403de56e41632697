#include "dh/sim/worker_ports.hpp"

#include "dh/sim/seam_core.hpp"

namespace dh::sim {

const Ports& worker_ports() {
  static const Ports p = [] {
    Ports all = SeamCore::ports();
    all.insert(all.end(),
               {
                   in_port<port::ChannelStatus>("other workers' channels: an action or lease for one of them "
                                                "is theirs, not refused as unknown"),
                   out_port<port::ChannelStatus>(
                       "each channel idle or running, with liveliness, so campaigns find a free channel"),
                   out_port<port::Camera>("with --cameras: each camera's image after every observation"),
                   in_port<port::RgbdRequest>("asks for one RGB-D frame of the workcell camera"),
                   out_port<port::Rgbd>("the RGB-D frame asked for"),
               });
    return all;
  }();
  return p;
}

}  // namespace dh::sim
