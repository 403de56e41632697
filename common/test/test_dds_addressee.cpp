// The addressee filter reads an observation's `addressee` straight from its serialized payload, on the
// writer's side: these tests serialize real messages with the generated type support, so a change to
// robot.idl that moves the field, or to its encoding, fails here rather than in a campaign that stalls.
#include <gtest/gtest.h>

#include <fastdds/dds/core/LoanableSequence.hpp>

#include "dh/common/convert.hpp"
#include "dh/common/dds_addressee.hpp"
#include "dh/msg/robotPubSubTypes.h"

using namespace dh;
using eprosima::fastrtps::rtps::GUID_t;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;

namespace {

GUID_t guid(std::uint8_t first) {
  GUID_t g;
  for (std::uint8_t i = 0; i < 12; ++i) g.guidPrefix.value[i] = static_cast<std::uint8_t>(first + i);
  g.entityId.value[3] = 7;
  return g;
}

SerializedPayload_t serialized(const std::string& addressee) {
  Observation o;
  o.step = 12;
  EntityState e;
  e.name = "bowl";
  e.kind = "bowl";
  o.entities = {e};
  msg::Observation m = convert::to_msg(o, 5, "goal/3/21#1");
  m.addressee(addressee);
  msg::ObservationPubSubType type;
  SerializedPayload_t payload(type.getSerializedSizeProvider(&m)());
  EXPECT_TRUE(type.serialize(&m, &payload));
  return payload;
}

bool passes(const SerializedPayload_t& p, const GUID_t& reader) {
  return dds::AddresseeFilter(dds::participant_address(reader)).evaluate(p, {}, reader);
}

}  // namespace

TEST(AddresseeFilter, ReadsTheAddresseeOfASerializedObservation) {
  const std::string a = dds::participant_address(guid(0x10));
  EXPECT_EQ(a, "101112131415161718191a1b");
  const auto p = serialized(a);
  ASSERT_TRUE(dds::addressee_in(p.data, p.length));
  EXPECT_EQ(*dds::addressee_in(p.data, p.length), a);
  const auto everyone = serialized("");
  ASSERT_TRUE(dds::addressee_in(everyone.data, everyone.length));
  EXPECT_TRUE(dds::addressee_in(everyone.data, everyone.length)->empty());
}

TEST(AddresseeFilter, PassesAStepToItsAddresseeAndToEveryoneWhenItIsForEveryone) {
  const GUID_t mine = guid(0x10), other = guid(0x40);
  const auto p = serialized(dds::participant_address(mine));
  EXPECT_TRUE(passes(p, mine));
  EXPECT_FALSE(passes(p, other));
  const auto everyone = serialized("");
  EXPECT_TRUE(passes(everyone, mine));
  EXPECT_TRUE(passes(everyone, other));
}

TEST(AddresseeFilter, AWritersHandleAndItsParticipantsReaderHaveOneAddress) {
  GUID_t writer = guid(0x20);
  writer.entityId.value[3] = 3;
  InstanceHandle_t handle;
  handle = writer;
  EXPECT_EQ(dds::participant_address(handle), dds::participant_address(guid(0x20)));
}

TEST(AddresseeFilter, LetsThroughWhatItCannotRead) {
  const std::uint8_t short_payload[6] = {0, 1, 0, 0, 5, 0};
  EXPECT_FALSE(dds::addressee_in(short_payload, sizeof short_payload));
  auto p = serialized(dds::participant_address(guid(0x10)));
  p.data[11] = 0x7f;  // the length's high byte: a length past the payload's end
  EXPECT_FALSE(dds::addressee_in(p.data, p.length));
  EXPECT_TRUE(passes(p, guid(0x40)));
}

TEST(AddresseeFilter, TheFactoryMakesAFilterForObservationsWithTheReadersAddress) {
  auto& f = dds::AddresseeFilterFactory::instance();
  eprosima::fastdds::dds::IContentFilter* filter = nullptr;
  const eprosima::fastdds::dds::LoanableSequence<const char*> none;
  EXPECT_EQ(f.create_content_filter(dds::kAddresseeFilter, "dh::msg::Action", nullptr,
                                    dds::kAddresseeExpression, none, filter),
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_BAD_PARAMETER);
  EXPECT_EQ(filter, nullptr);
  EXPECT_EQ(f.create_content_filter(dds::kAddresseeFilter, "dh::msg::Observation", nullptr,
                                    dds::kAddresseeExpression, none, filter),
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_BAD_PARAMETER)
      << "the reader's participant is its one parameter";
  const char* mine[] = {"101112131415161718191a1b"};
  eprosima::fastdds::dds::LoanableSequence<const char*> one;
  one.length(1);
  one[0] = mine[0];
  ASSERT_EQ(f.create_content_filter(dds::kAddresseeFilter, "dh::msg::Observation", nullptr,
                                    dds::kAddresseeExpression, one, filter),
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK);
  ASSERT_NE(filter, nullptr);
  EXPECT_TRUE(filter->evaluate(serialized(mine[0]), {}, guid(0x40)))
      << "the parameter decides, not the GUID the writer evaluates for";
  EXPECT_FALSE(filter->evaluate(serialized(dds::participant_address(guid(0x40))), {}, guid(0x40)));
  EXPECT_EQ(f.delete_content_filter(dds::kAddresseeFilter, filter),
            eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK);
}
