#include "dh/common/ports.hpp"

#include <fstream>
#include <stdexcept>

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

namespace dh {

std::set<std::string> port_table(const Ports& ports) {
  std::set<std::string> rows;
  for (const auto& p : ports)
    rows.insert("| " + std::string(p.direction == PortDirection::In ? "in" : "out") + " | " + std::string(p.topic) +
                " | " + std::string(p.type) + " | " + dds::to_string(p.qos) + " |");
  return rows;
}

std::set<std::string> port_table(const std::filesystem::path& readme) {
  std::ifstream in(readme);
  if (!in) throw std::runtime_error("cannot read " + readme.string());
  std::set<std::string> rows;
  for (std::string line; std::getline(in, line);)
    if (line.rfind("| in |", 0) == 0 || line.rfind("| out |", 0) == 0) rows.insert(line);
  return rows;
}

}  // namespace dh
