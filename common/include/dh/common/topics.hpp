// Every DDS topic name (ROS 2 naming: rt/dh/...), from the one topic table (topic_table.def), which also
// gives each topic's IDL type and QoS role (ports.hpp's port tags; QoS: dds.hpp, qos_for()).
#pragma once

namespace dh::topics {

#define DH_TOPIC(tag, name, type, qos) inline constexpr const char* k##tag = name;
#include "dh/common/topic_table.def"
#undef DH_TOPIC

}  // namespace dh::topics
