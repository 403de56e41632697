// Observations go to whom they are for (docs/processes.md, "Who gets an observation"). A step is the answer
// to one capability's action, and only that capability and the governor need it; the other capability
// processes would each receive, deserialize and drop every step of every channel. So the simulator writes
// into each observation the participant whose action led to it (`addressee`: the hex of its GUID prefix; ""
// for every reader), and readers that ask for it take the topic through a content filter of this class, which
// lets through what is theirs and what is for everyone. Fast DDS evaluates a custom filter on the writer's
// side when the writer's participant has the class registered too (every Participant registers it), so a
// filtered-out step is never sent to that reader.
#pragma once

#include <fastdds/rtps/common/Guid.h>
#include <fastdds/rtps/common/InstanceHandle.h>

#include <cstddef>
#include <cstdint>
#include <fastdds/dds/core/policy/ParameterTypes.hpp>
#include <fastdds/dds/topic/IContentFilterFactory.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace dh::dds {

/// The filter class every participant registers (Participant's constructor).
inline constexpr const char* kAddresseeFilter = "DH_ADDRESSEE";
/// The expression its readers give (Fast DDS announces a reader's filter only with a non-empty one); %0 is
/// the reader's participant_address.
inline constexpr const char* kAddresseeExpression = "addressee = '' OR addressee = %0";

/// The address of the participant that wrote a sample: the hex of the 12-byte GUID prefix of its writer.
std::string participant_address(const eprosima::fastrtps::rtps::InstanceHandle_t& writer);
/// The address of the participant a reader (or any entity) belongs to.
std::string participant_address(const eprosima::fastrtps::rtps::GUID_t& entity);

/// The `addressee` of a serialized observation: its encapsulation header, the channel (4 bytes), then the
/// string (robot.idl keeps it second). nullopt when the bytes are not such a payload.
std::optional<std::string_view> addressee_in(const std::uint8_t* data, std::size_t length);

/// The filter: a step for everyone, or for the reader's participant, passes; so does a payload it cannot read
/// (delivered rather than lost). The reader's participant is the filter's one parameter, not taken from the
/// GUID `evaluate` is given: Fast DDS tells a reader what the writer decided by the filter's signature
/// (class, expression, parameters), so readers whose results differ must have signatures that differ.
class AddresseeFilter : public eprosima::fastdds::dds::IContentFilter {
 public:
  explicit AddresseeFilter(std::string reader) : reader_(std::move(reader)) {}
  bool evaluate(const SerializedPayload& payload, const FilterSampleInfo&, const GUID_t&) const override;

 private:
  std::string reader_;
};

class AddresseeFilterFactory : public eprosima::fastdds::dds::IContentFilterFactory {
 public:
  ReturnCode_t create_content_filter(const char* filter_class_name, const char* type_name,
                                     const eprosima::fastdds::dds::TopicDataType* data_type,
                                     const char* filter_expression, const ParameterSeq& filter_parameters,
                                     eprosima::fastdds::dds::IContentFilter*& filter_instance) override;
  ReturnCode_t delete_content_filter(const char* filter_class_name,
                                     eprosima::fastdds::dds::IContentFilter* filter_instance) override;
  /// The one factory all participants share (it holds no state).
  static AddresseeFilterFactory& instance();
};

}  // namespace dh::dds
