#include "dh/sim/worker_ports.hpp"

#include "dh/common/topics.hpp"
#include "dh/sim/seam_core.hpp"

namespace dh::sim {

const Ports& worker_ports() {
  using enum PortDirection;
  static const Ports p = [] {
    Ports all = SeamCore::ports();
    all.insert(
        all.end(),
        {
            {In, topics::kChannelStatus, "dh::msg::ChannelStatus", dds::Qos::ChannelStatus,
             "other workers' channels: an action or lease for one of them is theirs, not refused as unknown"},
            {Out, topics::kChannelStatus, "dh::msg::ChannelStatus", dds::Qos::ChannelStatus,
             "each channel idle or running, with liveliness, so campaigns find a free channel"},
            {Out, topics::kCamera, "dh::msg::CameraImage", dds::Qos::Camera,
             "with --cameras: each camera's image after every observation"},
            {In, topics::kRgbdRequest, "dh::msg::RgbdRequest", dds::Qos::RgbdRequest,
             "asks for one RGB-D frame of the workcell camera"},
            {Out, topics::kRgbd, "dh::msg::RgbdFrame", dds::Qos::Rgbd, "the RGB-D frame asked for"},
        });
    return all;
  }();
  return p;
}

}  // namespace dh::sim
