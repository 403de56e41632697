#include "dh/common/ports.hpp"

namespace dh::dds {

const char* to_string(Qos q) {
  switch (q) {
    case Qos::Announce:
      return "Announce";
    case Qos::Command:
      return "Command";
    case Qos::Status:
      return "Status";
    case Qos::Lease:
      return "Lease";
    case Qos::Action:
      return "Action";
    case Qos::Observation:
      return "Observation";
    case Qos::Verdict:
      return "Verdict";
    case Qos::Planner:
      return "Planner";
    case Qos::Episode:
      return "Episode";
    case Qos::ChannelStatus:
      return "ChannelStatus";
    case Qos::Camera:
      return "Camera";
    case Qos::Rgbd:
      return "Rgbd";
    case Qos::RgbdRequest:
      return "RgbdRequest";
  }
  return "?";
}

}  // namespace dh::dds
