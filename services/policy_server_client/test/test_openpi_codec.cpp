// The openpi msgpack encoding on its own: observations as openpi's server reads them, replies and metadata
// as a server may write them (built here with msgpack-cxx, bin or str keys).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <msgpack.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dh/policy/openpi_codec.hpp"

using namespace dh::policy;

namespace {

struct Sink {
  std::string bytes;
  void write(const char* d, std::size_t n) { bytes.append(d, n); }
};
using Packer = msgpack::packer<Sink>;

void key(Packer& pk, std::string_view k, bool bin) {
  if (bin) {
    pk.pack_bin(k.size());
    pk.pack_bin_body(k.data(), k.size());
  } else {
    pk.pack_str(k.size());
    pk.pack_str_body(k.data(), k.size());
  }
}

void str(Packer& pk, std::string_view s) { key(pk, s, false); }

template <class T>
std::string le_bytes(const std::vector<T>& values) {
  std::string out;
  for (const T v : values) {
    using U = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
    const U bits = std::bit_cast<U>(v);
    for (std::size_t b = 0; b < sizeof(T); ++b) out.push_back(static_cast<char>((bits >> (8 * b)) & 0xff));
  }
  return out;
}

void ndarray(Packer& pk, std::string_view dtype, const std::vector<std::uint64_t>& shape,
             const std::string& data, bool bin_keys = true) {
  pk.pack_map(4);
  key(pk, "__ndarray__", bin_keys);
  pk.pack_true();
  key(pk, "data", bin_keys);
  pk.pack_bin(data.size());
  pk.pack_bin_body(data.data(), data.size());
  key(pk, "dtype", bin_keys);
  str(pk, dtype);
  key(pk, "shape", bin_keys);
  pk.pack_array(shape.size());
  for (auto d : shape) pk.pack_uint64(d);
}

std::vector<float> ramp(std::size_t n, float start = 0.5f) {
  std::vector<float> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = start + 0.125f * float(i);
  return v;
}

// {"actions": <ndarray>, "server_timing": {"infer_ms": 42}} with the given actions.
std::string reply(std::string_view dtype, const std::vector<std::uint64_t>& shape, const std::string& data,
                  bool bin_keys = true) {
  Sink s;
  Packer pk(s);
  pk.pack_map(2);
  str(pk, "actions");
  ndarray(pk, dtype, shape, data, bin_keys);
  str(pk, "server_timing");
  pk.pack_map(1);
  str(pk, "infer_ms");
  pk.pack_uint32(42);
  return s.bytes;
}

std::string error_of(std::string_view message) {
  try {
    decode_action_chunk(message);
  } catch (const PolicyCodecError& e) {
    return e.what();
  }
  return "";
}

PolicyQuery sample_query() {
  PolicyQuery q;
  q.agent_view = {"agentview", 224, 224, std::vector<std::uint8_t>(224 * 224 * 3)};
  q.wrist = {"wrist", 224, 224, std::vector<std::uint8_t>(224 * 224 * 3)};
  for (std::size_t i = 0; i < q.agent_view.rgb.size(); ++i) {
    q.agent_view.rgb[i] = static_cast<std::uint8_t>(i % 251);
    q.wrist.rgb[i] = static_cast<std::uint8_t>((i * 7) % 253);
  }
  q.state = {0.1f, -0.2f, 1.05f, 3.0f, -0.5f, 0.25f, 0.039f, -0.039f};
  q.prompt = "put the bowl on the plate";
  return q;
}

std::string_view text(const msgpack::object& o) {
  if (o.type == msgpack::type::STR) return {o.via.str.ptr, o.via.str.size};
  if (o.type == msgpack::type::BIN) return {o.via.bin.ptr, o.via.bin.size};
  ADD_FAILURE() << "not text: type " << int(o.type);
  return {};
}

}  // namespace

TEST(OpenpiCodec, ObservationIsOpenpisLiberoDictWithBinNdarrayKeys) {
  const auto q = sample_query();
  const std::string bytes = encode_observation(q);
  const auto handle = msgpack::unpack(bytes.data(), bytes.size());
  const auto& root = handle.get();
  ASSERT_EQ(root.type, msgpack::type::MAP);
  ASSERT_EQ(root.via.map.size, 4u);
  const char* keys[] = {"observation/image", "observation/wrist_image", "observation/state", "prompt"};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(root.via.map.ptr[i].key.type, msgpack::type::STR) << keys[i];  // the caller's keys: str
    EXPECT_EQ(text(root.via.map.ptr[i].key), keys[i]);
  }
  // Each ndarray: exactly openpi's four marker keys, as bin, in its order.
  const auto check_array = [](const msgpack::object& a, std::string_view dtype,
                              std::vector<std::uint64_t> shape, std::string_view data) {
    ASSERT_EQ(a.type, msgpack::type::MAP);
    ASSERT_EQ(a.via.map.size, 4u);
    const char* names[] = {"__ndarray__", "data", "dtype", "shape"};
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(a.via.map.ptr[i].key.type, msgpack::type::BIN) << names[i];
      EXPECT_EQ(text(a.via.map.ptr[i].key), names[i]);
    }
    EXPECT_EQ(a.via.map.ptr[0].val.type, msgpack::type::BOOLEAN);
    EXPECT_TRUE(a.via.map.ptr[0].val.via.boolean);
    ASSERT_EQ(a.via.map.ptr[1].val.type, msgpack::type::BIN);
    EXPECT_TRUE(text(a.via.map.ptr[1].val) == data);
    EXPECT_EQ(a.via.map.ptr[2].val.type, msgpack::type::STR);
    EXPECT_EQ(text(a.via.map.ptr[2].val), dtype);
    const auto& s = a.via.map.ptr[3].val;
    ASSERT_EQ(s.type, msgpack::type::ARRAY);
    ASSERT_EQ(s.via.array.size, shape.size());
    for (std::size_t i = 0; i < shape.size(); ++i) EXPECT_EQ(s.via.array.ptr[i].via.u64, shape[i]);
  };
  const auto bytes_of = [](const std::vector<std::uint8_t>& v) {
    return std::string_view(reinterpret_cast<const char*>(v.data()), v.size());
  };
  check_array(root.via.map.ptr[0].val, "|u1", {224, 224, 3}, bytes_of(q.agent_view.rgb));
  check_array(root.via.map.ptr[1].val, "|u1", {224, 224, 3}, bytes_of(q.wrist.rgb));
  const std::string state = le_bytes(std::vector<float>(q.state.begin(), q.state.end()));
  check_array(root.via.map.ptr[2].val, "<f4", {8}, state);
  EXPECT_EQ(root.via.map.ptr[3].val.type, msgpack::type::STR);
  EXPECT_EQ(text(root.via.map.ptr[3].val), q.prompt);
}

TEST(OpenpiCodec, ObservationShapeFollowsTheImage) {
  auto q = sample_query();
  q.agent_view = {"agentview", 5, 3, std::vector<std::uint8_t>(5 * 3 * 3, 9)};
  const std::string bytes = encode_observation(q);
  const auto handle = msgpack::unpack(bytes.data(), bytes.size());
  const auto& shape = handle.get().via.map.ptr[0].val.via.map.ptr[3].val;
  ASSERT_EQ(shape.via.array.size, 3u);
  EXPECT_EQ(shape.via.array.ptr[0].via.u64, 3u);  // height first
  EXPECT_EQ(shape.via.array.ptr[1].via.u64, 5u);
  EXPECT_EQ(shape.via.array.ptr[2].via.u64, 3u);
}

TEST(OpenpiCodec, ObservationRefusesInconsistentImages) {
  auto q = sample_query();
  q.wrist.rgb.pop_back();
  try {
    encode_observation(q);
    FAIL() << "accepted a short image";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("observation/wrist_image ('wrist')"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("150527 bytes"), std::string::npos) << e.what();
  }
  q = sample_query();
  q.agent_view = {};
  EXPECT_THROW(encode_observation(q), std::invalid_argument);
}

TEST(OpenpiCodec, DecodesFloat32ChunkWithBinKeys) {
  const auto values = ramp(10 * 7);
  const auto chunk = decode_action_chunk(reply("<f4", {10, 7}, le_bytes(values)));
  ASSERT_EQ(chunk.actions.size(), 10u);
  for (int r = 0; r < 10; ++r)
    for (int c = 0; c < 7; ++c) EXPECT_EQ(chunk.actions[r][c], double(values[r * 7 + c]));
  EXPECT_EQ(chunk.infer_ms, 42.0);
}

TEST(OpenpiCodec, DecodesFloat64ChunkWithStrKeysAndAnyHorizon) {
  std::vector<double> values(3 * 7);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = -1.0 + 0.1 * double(i);
  const auto chunk = decode_action_chunk(reply("<f8", {3, 7}, le_bytes(values), /*bin_keys=*/false));
  ASSERT_EQ(chunk.actions.size(), 3u);
  EXPECT_EQ(chunk.actions[2][6], values[20]);
  EXPECT_EQ(chunk.actions[0][0], -1.0);
  const auto one = decode_action_chunk(reply("<f4", {1, 7}, le_bytes(ramp(7))));
  EXPECT_EQ(one.actions.size(), 1u);
}

TEST(OpenpiCodec, ReadsInferMsFromNumberOrNumpyScalar) {
  const auto with_timing = [](auto&& pack_value) {
    Sink s;
    Packer pk(s);
    pk.pack_map(3);
    str(pk, "actions");
    ndarray(pk, "<f4", {1, 7}, le_bytes(ramp(7)));
    str(pk, "server_timing");
    pk.pack_map(2);
    str(pk, "infer_ms");
    pack_value(pk);
    str(pk, "prev_total_ms");
    pk.pack_double(80.0);
    str(pk, "extra");
    pk.pack_nil();
    return decode_action_chunk(s.bytes).infer_ms;
  };
  EXPECT_EQ(with_timing([](Packer& pk) { pk.pack_double(17.25); }), 17.25);
  EXPECT_EQ(with_timing([](Packer& pk) { pk.pack_float(2.5f); }), 2.5);
  // numpy scalar as openpi writes it: {__npgeneric__: true, data: value, dtype}
  EXPECT_EQ(with_timing([](Packer& pk) {
              pk.pack_map(3);
              key(pk, "__npgeneric__", true);
              pk.pack_true();
              key(pk, "data", true);
              pk.pack_double(9.5);
              key(pk, "dtype", true);
              str(pk, "<f8");
            }),
            9.5);
  // … and with the value as raw bytes
  EXPECT_EQ(with_timing([](Packer& pk) {
              pk.pack_map(3);
              key(pk, "__npgeneric__", false);
              pk.pack_true();
              key(pk, "data", false);
              const auto b = le_bytes(std::vector<double>{33.0});
              pk.pack_bin(b.size());
              pk.pack_bin_body(b.data(), b.size());
              key(pk, "dtype", false);
              str(pk, "<f8");
            }),
            33.0);
  // absent or not a number: 0
  EXPECT_EQ(with_timing([](Packer& pk) { str(pk, "fast"); }), 0.0);
  Sink s;
  Packer pk(s);
  pk.pack_map(1);
  str(pk, "actions");
  ndarray(pk, "<f4", {1, 7}, le_bytes(ramp(7)));
  EXPECT_EQ(decode_action_chunk(s.bytes).infer_ms, 0.0);
}

TEST(OpenpiCodec, RefusesWhatIsNotMsgpack) {
  EXPECT_NE(error_of(std::string("\xc1 not msgpack", 14)).find("the reply is not msgpack"),
            std::string::npos);
  EXPECT_NE(error_of(std::string("\xc1 not msgpack", 14)).find("starting c1 20 6e"), std::string::npos);
  EXPECT_NE(error_of("").find("empty"), std::string::npos);
  // truncated: a map header promising two entries and nothing more
  EXPECT_NE(error_of("\x82").find("not msgpack"), std::string::npos);
  // trailing bytes after a complete value
  const auto good = reply("<f4", {1, 7}, le_bytes(ramp(7)));
  EXPECT_NE(error_of(good + "\x01").find("1 bytes follow"), std::string::npos);
  // deeply nested arrays are refused, not recursed into
  EXPECT_NE(error_of(std::string(200, '\x91') + '\x01').find("not msgpack"), std::string::npos);
}

TEST(OpenpiCodec, RefusesRepliesWithoutActions) {
  Sink s;
  Packer pk(s);
  pk.pack_map(1);
  str(pk, "server_timing");
  pk.pack_map(0);
  const auto e = error_of(s.bytes);
  EXPECT_NE(e.find("no \"actions\""), std::string::npos) << e;
  EXPECT_NE(e.find("\"server_timing\""), std::string::npos) << e;
  Sink a;
  Packer pa(a);
  pa.pack_array(2);
  pa.pack_int(1);
  pa.pack_int(2);
  EXPECT_NE(error_of(a.bytes).find("an array of 2, not a map"), std::string::npos) << error_of(a.bytes);
}

TEST(OpenpiCodec, RefusesActionsThatAreNotAChunk) {
  const auto f4 = [](std::size_t n) { return le_bytes(ramp(n)); };
  EXPECT_NE(error_of(reply("<f4", {10, 6}, f4(60))).find("shape (10, 6), expected (H, 7)"),
            std::string::npos);
  EXPECT_NE(error_of(reply("<f4", {7}, f4(7))).find("shape (7,)"), std::string::npos);
  EXPECT_NE(error_of(reply("<f4", {1, 10, 7}, f4(70))).find("shape (1, 10, 7)"), std::string::npos);
  EXPECT_NE(error_of(reply("<f4", {0, 7}, "")).find("shape (0, 7)"), std::string::npos);
  EXPECT_NE(error_of(reply("<i8", {1, 7}, std::string(56, '\0'))).find("dtype \"<i8\""), std::string::npos);
  EXPECT_NE(error_of(reply(">f4", {1, 7}, f4(7))).find("dtype \">f4\""), std::string::npos);
  EXPECT_NE(error_of(reply("<f4", {10, 7}, f4(69))).find("needs 280 bytes of data, it has 276"),
            std::string::npos);
  EXPECT_NE(error_of(reply("<f4", {1, 7}, f4(7) + "x")).find("needs 28 bytes"), std::string::npos);
  // a huge claimed horizon with little data is refused, not allocated
  EXPECT_NE(error_of(reply("<f8", {std::uint64_t(1) << 62, 7}, f4(7))).find("bytes of data"),
            std::string::npos);
  auto nan = ramp(14);
  nan[9] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(error_of(reply("<f4", {2, 7}, le_bytes(nan))).find("\"actions\"[1][2]"), std::string::npos);

  // actions as a plain nested list, or an ndarray map without its marker or with missing fields
  Sink s;
  Packer pk(s);
  pk.pack_map(1);
  str(pk, "actions");
  pk.pack_array(1);
  pk.pack_array(7);
  for (int i = 0; i < 7; ++i) pk.pack_double(0.0);
  EXPECT_NE(error_of(s.bytes).find("not an openpi ndarray"), std::string::npos) << error_of(s.bytes);
  Sink m;
  Packer pm(m);
  pm.pack_map(1);
  str(pm, "actions");
  pm.pack_map(2);
  key(pm, "__ndarray__", true);
  pm.pack_true();
  key(pm, "dtype", true);
  str(pm, "<f4");
  EXPECT_NE(error_of(m.bytes).find("\"data\" is missing"), std::string::npos) << error_of(m.bytes);
}

TEST(OpenpiCodec, MetadataBecomesJson) {
  Sink s;
  Packer pk(s);
  pk.pack_map(5);
  str(pk, "policy");
  str(pk, "pi05_libero");
  key(pk, "action_horizon", true);  // a bin key reads as text too
  pk.pack_uint8(10);
  str(pk, "nested");
  pk.pack_map(2);
  str(pk, "list");
  pk.pack_array(3);
  pk.pack_int(-1);
  pk.pack_double(0.5);
  pk.pack_nil();
  str(pk, "flag");
  pk.pack_false();
  str(pk, "norm");
  ndarray(pk, "<f4", {2}, le_bytes(std::vector<float>{1.0f, 2.0f}));
  str(pk, "blob");
  pk.pack_bin(2);
  pk.pack_bin_body("\x01\x02", 2);
  const auto j = decode_metadata(s.bytes);
  EXPECT_EQ(j["policy"], "pi05_libero");
  EXPECT_EQ(j["action_horizon"], 10);
  EXPECT_EQ(j["nested"]["list"][0], -1);
  EXPECT_EQ(j["nested"]["list"][1], 0.5);
  EXPECT_TRUE(j["nested"]["list"][2].is_null());
  EXPECT_EQ(j["nested"]["flag"], false);
  EXPECT_EQ(j["norm"]["__ndarray__"], true);
  EXPECT_EQ(j["norm"]["dtype"], "<f4");
  EXPECT_TRUE(j["blob"].is_binary());
  EXPECT_EQ(j["blob"].get_binary().size(), 2u);

  Sink empty;
  Packer pe(empty);
  pe.pack_map(0);
  EXPECT_TRUE(decode_metadata(empty.bytes).is_object());
  EXPECT_TRUE(decode_metadata(empty.bytes).empty());
  EXPECT_THROW(decode_metadata("\xc1"), PolicyCodecError);
  EXPECT_THROW(decode_metadata("\x01"), PolicyCodecError);  // an integer, not a map
}
