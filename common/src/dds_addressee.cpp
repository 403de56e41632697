#include "dh/common/dds_addressee.hpp"

#include <cstring>

namespace dh::dds {

namespace {
std::string hex(const std::uint8_t* b, std::size_t n) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    s[2 * i] = kDigits[b[i] >> 4];
    s[2 * i + 1] = kDigits[b[i] & 0xf];
  }
  return s;
}

constexpr std::size_t kPrefixBytes = 12;
constexpr std::size_t kHeaderBytes = 4;   // CDR encapsulation: representation id, options
constexpr std::size_t kChannelBytes = 4;  // @key unsigned long channel
}  // namespace

std::string participant_address(const eprosima::fastrtps::rtps::GUID_t& entity) {
  return hex(entity.guidPrefix.value, kPrefixBytes);
}

std::string participant_address(const eprosima::fastrtps::rtps::InstanceHandle_t& writer) {
  return participant_address(eprosima::fastrtps::rtps::iHandle2GUID(writer));
}

std::optional<std::string_view> addressee_in(const std::uint8_t* data, std::size_t length) {
  constexpr std::size_t at = kHeaderBytes + kChannelBytes;
  if (!data || length < at + 4 || data[0] != 0) return std::nullopt;
  // Representation 0x0000 is plain CDR big-endian, 0x0001 little-endian (DDS-XTypes 7.6.3.1.2).
  const bool little = (data[1] & 1) != 0;
  const std::uint32_t n = little ? (std::uint32_t(data[at]) | std::uint32_t(data[at + 1]) << 8 |
                                    std::uint32_t(data[at + 2]) << 16 | std::uint32_t(data[at + 3]) << 24)
                                 : (std::uint32_t(data[at]) << 24 | std::uint32_t(data[at + 1]) << 16 |
                                    std::uint32_t(data[at + 2]) << 8 | std::uint32_t(data[at + 3]));
  // A CDR string's length counts its terminating NUL.
  if (n == 0 || n > length - at - 4 || data[at + 4 + n - 1] != 0) return std::nullopt;
  return std::string_view(reinterpret_cast<const char*>(data + at + 4), n - 1);
}

bool AddresseeFilter::evaluate(const SerializedPayload& payload, const FilterSampleInfo&,
                               const GUID_t&) const {
  const auto to = addressee_in(payload.data, payload.length);
  return !to || to->empty() || *to == reader_;
}

AddresseeFilterFactory::ReturnCode_t AddresseeFilterFactory::create_content_filter(
    const char* filter_class_name, const char* type_name, const eprosima::fastdds::dds::TopicDataType*,
    const char*, const ParameterSeq& filter_parameters,
    eprosima::fastdds::dds::IContentFilter*& filter_instance) {
  if (std::strcmp(filter_class_name, kAddresseeFilter) != 0 ||
      std::strcmp(type_name, "dh::msg::Observation") != 0 || filter_parameters.length() != 1 ||
      !filter_parameters[0])
    return ReturnCode_t::RETCODE_BAD_PARAMETER;
  // Called again with new parameters for an existing filter: the old one goes, as the interface allows.
  delete static_cast<AddresseeFilter*>(filter_instance);
  filter_instance = new AddresseeFilter(filter_parameters[0]);
  return ReturnCode_t::RETCODE_OK;
}

AddresseeFilterFactory::ReturnCode_t AddresseeFilterFactory::delete_content_filter(
    const char*, eprosima::fastdds::dds::IContentFilter* filter_instance) {
  delete static_cast<AddresseeFilter*>(filter_instance);
  return ReturnCode_t::RETCODE_OK;
}

AddresseeFilterFactory& AddresseeFilterFactory::instance() {
  static AddresseeFilterFactory f;
  return f;
}

}  // namespace dh::dds
