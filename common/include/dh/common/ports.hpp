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
  RgbdRequest,    ///< reliable, volatile, keep-last 64 (asks for one RGB-D frame)
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

}  // namespace dh

// The generated IDL classes, declared only: a core names its messages' types without including DDS.
namespace dh::msg {
#define DH_TOPIC(tag, name, type, qos) class type; class type##PubSubType;
#include "dh/common/topic_table.def"
#undef DH_TOPIC
}  // namespace dh::msg

/// One tag per topic of topic_table.def: its name, IDL type and QoS role. Cores declare their ports with
/// them (in_port / out_port); the DDS shell (dds_shell.hpp) makes readers and writers from them.
namespace dh::port {
#define DH_TOPIC(tag, name, idl_type, qos_role)                    \
  struct tag {                                                     \
    static constexpr std::string_view topic = name;                \
    static constexpr std::string_view type = "dh::msg::" #idl_type; \
    static constexpr dds::Qos qos = dds::Qos::qos_role;            \
    using Msg = msg::idl_type;                                     \
    using PubSub = msg::idl_type##PubSubType;                      \
  };
#include "dh/common/topic_table.def"
#undef DH_TOPIC
}  // namespace dh::port

namespace dh {

/// A port row of `Tag`'s topic, in or out, with one line on what flows on it and when.
template <class Tag>
Port in_port(std::string_view what) {
  return {PortDirection::In, Tag::topic, Tag::type, Tag::qos, what};
}
template <class Tag>
Port out_port(std::string_view what) {
  return {PortDirection::Out, Tag::topic, Tag::type, Tag::qos, what};
}

/// The rows of a service README's port table ("| in | rt/dh/... | dh::msg::... | Qos |"), as a core
/// declares them and as a README lists them (lines starting "| in |" or "| out |"); a test compares the two.
std::set<std::string> port_table(const Ports& ports);
/// Throws std::runtime_error naming `readme` when it cannot be read.
std::set<std::string> port_table(const std::filesystem::path& readme);

}  // namespace dh
