// A service core's ports, declared in code next to the core (as BehaviorTree.CPP's providedPorts() or
// Drake's declared ports): the topic, the IDL type and the QoS role of everything it reads and writes.
// DDS-free: the DDS shell maps a QoS role to Fast DDS QoS (dds.hpp, qos_for); the in-process bus ignores it.
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace dh::dds {

/// The QoS classes of DESIGN.md §3.
enum class Qos {
  Announce,     ///< reliable, transient-local, liveliness MANUAL_BY_TOPIC lease 1 s (a Heartbeat asserts it)
  Command,      ///< reliable, keep-last 1 per channel
  Status,       ///< reliable, keep-last 16
  Lease,        ///< reliable, keep-last 1, deadline 1 s
  Action,       ///< reliable, keep-last 1
  Observation,  ///< reliable, transient-local, keep-last 1
  Verdict,      ///< reliable, keep-all
  Planner,      ///< reliable, keep-last 8
  Episode,      ///< reliable, transient-local, keep-last 1 per channel
  ChannelStatus,  ///< as Episode, plus liveliness MANUAL_BY_TOPIC lease kChannelLivelinessSec (a Heartbeat
                  ///< asserts it): a dead or cut-off simulator worker is noticed by campaigns
  Camera,         ///< reliable, transient-local, keep-last 1 per channel and camera (150 KB samples)
  Rgbd,           ///< RGB-D frames (~1.5 MB): see qos_for for the choice and its measurement
  RgbdRequest,    ///< reliable, volatile, keep-last 8 (asks for one RGB-D frame)
};

/// The role's name as the services' READMEs list it ("Command", "Observation", ...).
const char* to_string(Qos q);

}  // namespace dh::dds

namespace dh {

enum class PortDirection { In, Out };

struct Port {
  PortDirection direction;
  std::string_view topic;  ///< rt/dh/... (topics.hpp)
  std::string_view type;   ///< the IDL type, e.g. "dh::msg::Command"
  dds::Qos qos;
  std::string_view what;  ///< one line: what flows on it and when
};

using Ports = std::vector<Port>;

/// The rows of a service README's port table ("| in | rt/dh/... | dh::msg::... | Qos |"), as a core
/// declares them and as a README lists them (lines starting "| in |" or "| out |"); a test compares the two.
std::set<std::string> port_table(const Ports& ports);
/// Throws std::runtime_error naming `readme` when it cannot be read.
std::set<std::string> port_table(const std::filesystem::path& readme);

}  // namespace dh
