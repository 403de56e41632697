// The RTDE protocol's bytes against sequences written out by hand from UR's published package layouts
// (docs/ur-rtde.md: RTDE guide, UniversalRobots/RTDE_Python_Client_Library rtde/serialize.py,
// Universal_Robots_Client_Library rtde/*): big-endian, a uint16 size that counts the 3-byte header, a
// uint8 type, then the payload.
#include <gtest/gtest.h>

#include "dh/rtde/protocol.hpp"

using namespace dh::rtde;
using Bytes = std::vector<std::uint8_t>;

namespace {
Bytes bytes(const std::string& s) { return Bytes(s.begin(), s.end()); }
Bytes cat(Bytes a, const Bytes& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}
}  // namespace

TEST(RtdeProtocol, RequestsAreFramedAsUrPublishesThem) {
  // REQUEST_PROTOCOL_VERSION 'V' (86) offering version 2: size 5, type, uint16 2.
  EXPECT_EQ(encode(request_protocol_version()), (Bytes{0x00, 0x05, 0x56, 0x00, 0x02}));
  // GET_URCONTROL_VERSION 'v', START 'S', PAUSE 'P': a header and no payload.
  EXPECT_EQ(encode(get_urcontrol_version()), (Bytes{0x00, 0x03, 0x76}));
  EXPECT_EQ(encode(request_start()), (Bytes{0x00, 0x03, 0x53}));
  EXPECT_EQ(encode(request_pause()), (Bytes{0x00, 0x03, 0x50}));
  // CONTROL_PACKAGE_SETUP_OUTPUTS 'O' (v2): a double frequency (125.0 = 0x405F400000000000), then the
  // names, comma-separated.
  const Bytes names = bytes("timestamp,actual_q");
  const Bytes want = cat(cat(Bytes{0x00, static_cast<std::uint8_t>(3 + 8 + names.size()), 0x4f},
                             Bytes{0x40, 0x5f, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00}),
                         names);
  EXPECT_EQ(encode(setup_outputs(125.0, {"timestamp", "actual_q"})), want);
  // CONTROL_PACKAGE_SETUP_INPUTS 'I': the names only.
  EXPECT_EQ(encode(setup_inputs({"input_int_register_24"})),
            cat(Bytes{0x00, 3 + 21, 0x49}, bytes("input_int_register_24")));
  EXPECT_THROW(setup_inputs({"a,b"}), ProtocolError) << "a comma inside a name would split it";
}

TEST(RtdeProtocol, RepliesAreReadAndWhatTheControllerRefusesIsNamed) {
  // Setup reply: uint8 recipe id, then the types, comma-separated.
  const Package ok{PackageType::SetupOutputs, cat(Bytes{0x01}, bytes("DOUBLE,VECTOR6D,INT32"))};
  const Recipe r = recipe(ok, PackageType::SetupOutputs, {"timestamp", "actual_q", "safety_mode"});
  EXPECT_EQ(r.id, 1);
  EXPECT_EQ(r.types, (std::vector<FieldType>{FieldType::Double, FieldType::Vector6d, FieldType::Int32}));
  const Package refused{PackageType::SetupInputs, cat(Bytes{0x02}, bytes("INT32,IN_USE,NOT_FOUND"))};
  try {
    recipe(refused, PackageType::SetupInputs,
           {"input_int_register_24", "input_double_register_24", "speed_x"});
    ADD_FAILURE() << "a refused recipe was accepted";
  } catch (const ProtocolError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("input_double_register_24 (IN_USE)"), std::string::npos) << what;
    EXPECT_NE(what.find("speed_x (NOT_FOUND)"), std::string::npos) << what;
    EXPECT_EQ(what.find("input_int_register_24 ("), std::string::npos) << what;
  }
  EXPECT_THROW(recipe(ok, PackageType::SetupOutputs, {"timestamp"}), ProtocolError)
      << "three types for one name";
  EXPECT_THROW(recipe(ok, PackageType::SetupInputs, {"a", "b", "c"}), ProtocolError)
      << "a reply of another type";
  // Accepted flags, the controller's version (4 × uint32) and a v2 text message.
  EXPECT_TRUE(accepted({PackageType::RequestProtocolVersion, {0x01}}, PackageType::RequestProtocolVersion));
  EXPECT_FALSE(accepted({PackageType::Start, {0x00}}, PackageType::Start));
  EXPECT_THROW(accepted({PackageType::Start, {}}, PackageType::Start), ProtocolError) << "no flag";
  const ControllerVersion v = urcontrol_version(
      {PackageType::GetUrcontrolVersion, {0, 0, 0, 5, 0, 0, 0, 15, 0, 0, 0, 2, 0, 0, 0x30, 0x39}});
  EXPECT_EQ(v.major, 5u);
  EXPECT_EQ(v.minor, 15u);
  EXPECT_EQ(v.bugfix, 2u);
  EXPECT_EQ(v.build, 12345u);
  const TextMessage m =
      text_message({PackageType::TextMessage,
                    cat(cat(Bytes{5}, bytes("hello")), cat(cat(Bytes{3}, bytes("RTD")), Bytes{2}))});
  EXPECT_EQ(m.message, "hello");
  EXPECT_EQ(m.source, "RTD");
  EXPECT_EQ(m.level, 2) << "a warning";
  EXPECT_EQ(text_message(text_message_package(m)).message, "hello");
}

TEST(RtdeProtocol, DataPackagesCarryTheRecipeIdAndItsFieldsInOrder) {
  const Recipe r{
      3,
      {"timestamp", "actual_q", "safety_status_bits", "actual_digital_input_bits", "flag"},
      {FieldType::Double, FieldType::Vector6d, FieldType::Uint32, FieldType::Uint64, FieldType::Bool}};
  const std::vector<Value> values{1.5, std::array<double, 6>{0, -1.5707963267948966, 1, 2, 3, -0.25},
                                  std::uint32_t{1u << 2}, std::uint64_t{0x0102030405060708ull}, true};
  const Package p = data_package(r, values);
  ASSERT_EQ(p.payload.size(), 1u + 8 + 48 + 4 + 8 + 1);
  EXPECT_EQ(p.payload[0], 3) << "the recipe id first";
  EXPECT_EQ(Bytes(p.payload.begin() + 1, p.payload.begin() + 9), (Bytes{0x3f, 0xf8, 0, 0, 0, 0, 0, 0}))
      << "1.5";
  EXPECT_EQ(Bytes(p.payload.begin() + 57, p.payload.begin() + 61), (Bytes{0, 0, 0, 4}))
      << "bit 2: protective stop";
  EXPECT_EQ(data_values(p, r), values) << "read back bit for bit";
  // A value of another type, a count that is not the recipe's, a package of another recipe or length.
  EXPECT_THROW(data_package(r, {1.5}), ProtocolError);
  std::vector<Value> wrong = values;
  wrong[2] = std::int32_t{4};
  EXPECT_THROW(data_package(r, wrong), ProtocolError);
  Package other = p;
  other.payload[0] = 4;
  EXPECT_THROW(data_values(other, r), ProtocolError);
  Package longer = p;
  longer.payload.push_back(0);
  EXPECT_THROW(data_values(longer, r), ProtocolError);
  Package shorter = p;
  shorter.payload.pop_back();
  EXPECT_THROW(data_values(shorter, r), ProtocolError);
  // Negative int32 round-trips through its two's complement.
  const Recipe ints{1, {"safety_mode", "joint_mode"}, {FieldType::Int32, FieldType::Vector6Int32}};
  const std::vector<Value> iv{std::int32_t{-1}, std::array<std::int32_t, 6>{253, -1, 0, 1, 2, 3}};
  EXPECT_EQ(data_values(data_package(ints, iv), ints), iv);
}

TEST(RtdeProtocol, AStreamIsCutIntoPackagesHoweverItArrives) {
  const Bytes stream = cat(cat(encode(request_start()), encode(setup_inputs({"input_int_register_24"}))),
                           encode(accepted_reply(PackageType::Start, true)));
  PackageReader reader;
  std::vector<Package> got;
  for (std::uint8_t b : stream) {  // one byte at a time: the worst a TCP read can do
    reader.feed(std::span(&b, 1));
    while (auto p = reader.next()) got.push_back(*p);
  }
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0].type, PackageType::Start);
  EXPECT_EQ(setup_names(got[1]), (std::vector<std::string>{"input_int_register_24"}));
  EXPECT_TRUE(accepted(got[2], PackageType::Start));
  EXPECT_EQ(reader.buffered(), 0u);
  PackageReader bad;
  const Bytes garbage{0x00, 0x01, 0x53};
  bad.feed(garbage);
  EXPECT_THROW(bad.next(), ProtocolError) << "a size below the header's is not RTDE";
  EXPECT_THROW(encode({PackageType::DataPackage, Bytes(70000, 0)}), ProtocolError);
}

TEST(RtdeProtocol, TheControllerSideReadsRequestsAndAnswersThem) {
  double f = 0;
  EXPECT_EQ(setup_names(setup_outputs(500.0, {"actual_q", "actual_TCP_pose"}), &f),
            (std::vector<std::string>{"actual_q", "actual_TCP_pose"}));
  EXPECT_EQ(f, 500.0);
  const Package reply = setup_reply(PackageType::SetupOutputs, 1, {FieldType::Vector6d, std::nullopt});
  EXPECT_EQ(reply.payload, cat(Bytes{1}, bytes("VECTOR6D,NOT_FOUND")));
  EXPECT_EQ(urcontrol_version(urcontrol_version_reply({5, 11, 1, 108})).build, 108u);
  EXPECT_EQ(to_string(PackageType::SetupOutputs), "CONTROL_PACKAGE_SETUP_OUTPUTS");
  EXPECT_EQ(to_string(static_cast<PackageType>(0x41)), "type 0x41");
}
