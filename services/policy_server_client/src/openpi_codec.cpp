#include "dh/policy/openpi_codec.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <msgpack.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

namespace dh::policy {

namespace {

// Nesting deeper than this is refused while parsing (no message of the protocol comes close).
constexpr std::size_t kMaxDepth = 64;

// Appends what msgpack's packer writes to a string (the frame sent as is).
struct StringSink {
  std::string bytes;
  void write(const char* data, std::size_t size) { bytes.append(data, size); }
};
using Packer = msgpack::packer<StringSink>;

void pack_str(Packer& pk, std::string_view s) {
  pk.pack_str(static_cast<std::uint32_t>(s.size()));
  pk.pack_str_body(s.data(), static_cast<std::uint32_t>(s.size()));
}

// openpi writes the keys of its own ndarray map as Python bytes: msgpack bin.
void pack_bin_key(Packer& pk, std::string_view s) {
  pk.pack_bin(static_cast<std::uint32_t>(s.size()));
  pk.pack_bin_body(s.data(), static_cast<std::uint32_t>(s.size()));
}

// openpi_client.msgpack_numpy.pack_array's map, in its key order.
void pack_ndarray(Packer& pk, std::string_view dtype, const std::vector<std::uint64_t>& shape,
                  const void* data, std::size_t size) {
  pk.pack_map(4);
  pack_bin_key(pk, "__ndarray__");
  pk.pack_true();
  pack_bin_key(pk, "data");
  pk.pack_bin(static_cast<std::uint32_t>(size));
  pk.pack_bin_body(static_cast<const char*>(data), static_cast<std::uint32_t>(size));
  pack_bin_key(pk, "dtype");
  pack_str(pk, dtype);
  pack_bin_key(pk, "shape");
  pk.pack_array(static_cast<std::uint32_t>(shape.size()));
  for (const auto d : shape) pk.pack_uint64(d);
}

void check_image(const CameraImage& image, const char* field) {
  const std::string label = std::string(field) + (image.name.empty() ? "" : " ('" + image.name + "')");
  if (image.width <= 0 || image.height <= 0)
    throw std::invalid_argument(label + ": empty image (" + std::to_string(image.width) + " × " +
                                std::to_string(image.height) + ")");
  const auto expected = std::size_t(image.width) * std::size_t(image.height) * 3;
  if (image.rgb.size() != expected)
    throw std::invalid_argument(label + ": " + std::to_string(image.rgb.size()) + " bytes for a " +
                                std::to_string(image.width) + " × " + std::to_string(image.height) +
                                " RGB image (expected " + std::to_string(expected) + ")");
}

void pack_image(Packer& pk, const CameraImage& image) {
  pack_ndarray(pk, "|u1", {std::uint64_t(image.height), std::uint64_t(image.width), 3}, image.rgb.data(),
               image.rgb.size());
}

// --- reading ---------------------------------------------------------------------------------------

// The first bytes of a message in hex, for messages about it.
std::string hex_head(std::string_view message) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < std::min<std::size_t>(message.size(), 8); ++i) {
    const auto b = static_cast<unsigned char>(message[i]);
    out += (i ? " " : "");
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out + (message.size() > 8 ? " …" : "");
}

msgpack::object_handle parse_one(std::string_view message, const char* what) {
  if (message.empty()) throw PolicyCodecError(std::string(what) + " is empty (0 bytes), not msgpack");
  std::size_t offset = 0;
  msgpack::object_handle handle;
  try {
    const msgpack::unpack_limit limit(0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, kMaxDepth);
    handle = msgpack::unpack(message.data(), message.size(), offset, nullptr, nullptr, limit);
  } catch (const std::exception& e) {
    throw PolicyCodecError(std::string(what) + " is not msgpack (" + e.what() + "; " +
                           std::to_string(message.size()) + " bytes, starting " + hex_head(message) + ")");
  }
  if (offset != message.size())
    throw PolicyCodecError(std::string(what) +
                           " is not one msgpack value: " + std::to_string(message.size() - offset) +
                           " bytes follow the first " + std::to_string(offset));
  return handle;
}

std::optional<std::string_view> text_of(const msgpack::object& o) {
  if (o.type == msgpack::type::STR) return std::string_view(o.via.str.ptr, o.via.str.size);
  if (o.type == msgpack::type::BIN) return std::string_view(o.via.bin.ptr, o.via.bin.size);
  return std::nullopt;
}

const msgpack::object* find(const msgpack::object& map, std::string_view key) {
  if (map.type != msgpack::type::MAP) return nullptr;
  for (std::uint32_t i = 0; i < map.via.map.size; ++i) {
    const auto& kv = map.via.map.ptr[i];
    if (text_of(kv.key) == key) return &kv.val;
  }
  return nullptr;
}

std::string keys_of(const msgpack::object& map) {
  std::string out;
  for (std::uint32_t i = 0; i < map.via.map.size; ++i) {
    const auto t = text_of(map.via.map.ptr[i].key);
    out += (i ? ", " : "") + (t ? "\"" + std::string(*t) + "\"" : std::string("<non-text key>"));
  }
  return out.empty() ? "none" : out;
}

std::string describe(const msgpack::object& o) {
  switch (o.type) {
    case msgpack::type::NIL:
      return "nil";
    case msgpack::type::BOOLEAN:
      return o.via.boolean ? "true" : "false";
    case msgpack::type::POSITIVE_INTEGER:
    case msgpack::type::NEGATIVE_INTEGER:
      return "an integer";
    case msgpack::type::FLOAT32:
    case msgpack::type::FLOAT64:
      return "a float";
    case msgpack::type::STR:
      return "a str of " + std::to_string(o.via.str.size) + " bytes";
    case msgpack::type::BIN:
      return "bin of " + std::to_string(o.via.bin.size) + " bytes";
    case msgpack::type::ARRAY:
      return "an array of " + std::to_string(o.via.array.size);
    case msgpack::type::MAP:
      return "a map with keys " + keys_of(o);
    case msgpack::type::EXT:
      return "an ext value";
  }
  return "an unknown msgpack value";
}

bool is_marked(const msgpack::object& o, std::string_view marker) {
  const auto* v = find(o, marker);
  return v && v->type == msgpack::type::BOOLEAN && v->via.boolean;
}

std::optional<double> number_of(const msgpack::object& o) {
  switch (o.type) {
    case msgpack::type::POSITIVE_INTEGER:
      return double(o.via.u64);
    case msgpack::type::NEGATIVE_INTEGER:
      return double(o.via.i64);
    case msgpack::type::FLOAT32:
    case msgpack::type::FLOAT64:
      return o.via.f64;
    default:
      return std::nullopt;
  }
}

std::uint64_t load_le(const char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v |= std::uint64_t(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}

// A number, or a numpy scalar {"__npgeneric__": true, "data": value or raw bytes, "dtype": "<f8" …}.
std::optional<double> scalar_of(const msgpack::object& o) {
  if (auto n = number_of(o)) return n;
  if (o.type != msgpack::type::MAP || !is_marked(o, "__npgeneric__")) return std::nullopt;
  const auto* data = find(o, "data");
  if (!data) return std::nullopt;
  if (auto n = number_of(*data)) return n;
  const auto* dtype = find(o, "dtype");
  if (data->type != msgpack::type::BIN || !dtype || !text_of(*dtype)) return std::nullopt;
  const std::string_view t = *text_of(*dtype), bytes(data->via.bin.ptr, data->via.bin.size);
  if (t == "<f8" && bytes.size() == 8) return std::bit_cast<double>(load_le(bytes.data(), 8));
  if (t == "<f4" && bytes.size() == 4)
    return double(std::bit_cast<float>(static_cast<std::uint32_t>(load_le(bytes.data(), 4))));
  if ((t == "<i8" || t == "<i4") && bytes.size() == (t == "<i8" ? 8u : 4u)) {
    const auto raw = load_le(bytes.data(), bytes.size());
    return t == "<i8" ? double(static_cast<std::int64_t>(raw)) : double(static_cast<std::int32_t>(raw));
  }
  return std::nullopt;
}

std::string shape_text(const std::vector<std::uint64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

struct NdArray {
  std::string dtype;
  std::vector<std::uint64_t> shape;
  std::string_view data;
};

NdArray as_ndarray(const msgpack::object& o, const std::string& name) {
  if (o.type != msgpack::type::MAP || !is_marked(o, "__ndarray__"))
    throw PolicyCodecError(name + " is not an openpi ndarray ({\"__ndarray__\": true, \"data\", \"dtype\", " +
                           "\"shape\"}) but " + describe(o));
  NdArray a;
  const auto* data = find(o, "data");
  const auto* dtype = find(o, "dtype");
  const auto* shape = find(o, "shape");
  if (!data || data->type != msgpack::type::BIN)
    throw PolicyCodecError(name + ": the ndarray's \"data\" is " + (data ? describe(*data) : "missing") +
                           ", expected bin");
  if (!dtype || !text_of(*dtype))
    throw PolicyCodecError(name + ": the ndarray's \"dtype\" is " + (dtype ? describe(*dtype) : "missing") +
                           ", expected a str such as \"<f4\"");
  if (!shape || shape->type != msgpack::type::ARRAY)
    throw PolicyCodecError(name + ": the ndarray's \"shape\" is " + (shape ? describe(*shape) : "missing") +
                           ", expected an array of sizes");
  a.data = std::string_view(data->via.bin.ptr, data->via.bin.size);
  a.dtype = std::string(*text_of(*dtype));
  for (std::uint32_t i = 0; i < shape->via.array.size; ++i) {
    const auto& d = shape->via.array.ptr[i];
    if (d.type != msgpack::type::POSITIVE_INTEGER)
      throw PolicyCodecError(name + ": the ndarray's \"shape\" holds " + describe(d) +
                             ", expected non-negative integers");
    a.shape.push_back(d.via.u64);
  }
  return a;
}

nlohmann::json to_json(const msgpack::object& o) {
  switch (o.type) {
    case msgpack::type::NIL:
      return nullptr;
    case msgpack::type::BOOLEAN:
      return o.via.boolean;
    case msgpack::type::POSITIVE_INTEGER:
      return o.via.u64;
    case msgpack::type::NEGATIVE_INTEGER:
      return o.via.i64;
    case msgpack::type::FLOAT32:
    case msgpack::type::FLOAT64:
      return o.via.f64;
    case msgpack::type::STR:
      return std::string(o.via.str.ptr, o.via.str.size);
    case msgpack::type::BIN: {
      const auto* p = reinterpret_cast<const std::uint8_t*>(o.via.bin.ptr);
      return nlohmann::json::binary(std::vector<std::uint8_t>(p, p + o.via.bin.size));
    }
    case msgpack::type::EXT: {
      const auto* p = reinterpret_cast<const std::uint8_t*>(o.via.ext.data());
      return nlohmann::json::binary(std::vector<std::uint8_t>(p, p + o.via.ext.size),
                                    static_cast<std::uint8_t>(o.via.ext.type()));
    }
    case msgpack::type::ARRAY: {
      auto out = nlohmann::json::array();
      for (std::uint32_t i = 0; i < o.via.array.size; ++i) out.push_back(to_json(o.via.array.ptr[i]));
      return out;
    }
    case msgpack::type::MAP: {
      auto out = nlohmann::json::object();
      for (std::uint32_t i = 0; i < o.via.map.size; ++i) {
        const auto& kv = o.via.map.ptr[i];
        const auto text = text_of(kv.key);
        const auto key = text ? std::string(*text) : to_json(kv.key).dump();
        out[key] = to_json(kv.val);
      }
      return out;
    }
  }
  return nullptr;
}

}  // namespace

std::string encode_observation(const PolicyQuery& query) {
  check_image(query.agent_view, "observation/image");
  check_image(query.wrist, "observation/wrist_image");
  StringSink sink;
  sink.bytes.reserve(query.agent_view.rgb.size() + query.wrist.rgb.size() + query.prompt.size() + 512);
  Packer pk(sink);
  pk.pack_map(4);
  pack_str(pk, "observation/image");
  pack_image(pk, query.agent_view);
  pack_str(pk, "observation/wrist_image");
  pack_image(pk, query.wrist);
  pack_str(pk, "observation/state");
  std::string state;  // little-endian float32, whatever the host's byte order
  for (const float v : query.state) {
    const auto bits = std::bit_cast<std::uint32_t>(v);
    for (int b = 0; b < 4; ++b) state.push_back(static_cast<char>((bits >> (8 * b)) & 0xff));
  }
  pack_ndarray(pk, "<f4", {std::uint64_t(query.state.size())}, state.data(), state.size());
  pack_str(pk, "prompt");
  pack_str(pk, query.prompt);
  return std::move(sink.bytes);
}

ActionChunk decode_action_chunk(std::string_view message) {
  const auto handle = parse_one(message, "the reply");
  const auto& root = handle.get();
  if (root.type != msgpack::type::MAP)
    throw PolicyCodecError("the reply is " + describe(root) + ", not a map (openpi's action dict)");
  const auto* actions = find(root, "actions");
  if (!actions)
    throw PolicyCodecError("the reply has no \"actions\" (its keys: " + keys_of(root) +
                           "); expected openpi's action dict {\"actions\": ndarray (H, 7), …}");
  const auto a = as_ndarray(*actions, "\"actions\"");
  if (a.shape.size() != 2 || a.shape[0] < 1 || a.shape[1] != std::uint64_t(kOpenpiActionDims))
    throw PolicyCodecError("\"actions\" has shape " + shape_text(a.shape) + ", expected (H, " +
                           std::to_string(kOpenpiActionDims) + ") with H >= 1");
  std::size_t item = 0;
  if (a.dtype == "<f4") item = 4;
  if (a.dtype == "<f8") item = 8;
  if (item == 0)
    throw PolicyCodecError("\"actions\" has dtype \"" + a.dtype +
                           "\", expected \"<f4\" (float32) or \"<f8\" (float64)");
  const auto rows = a.shape[0];
  if (rows > a.data.size() || a.data.size() != rows * kOpenpiActionDims * item)
    throw PolicyCodecError("\"actions\" " + shape_text(a.shape) + " " + a.dtype + " needs " +
                           std::to_string(rows * kOpenpiActionDims * item) + " bytes of data, it has " +
                           std::to_string(a.data.size()));
  ActionChunk chunk;
  chunk.actions.resize(rows);
  const char* p = a.data.data();
  for (std::uint64_t r = 0; r < rows; ++r) {
    for (int c = 0; c < kOpenpiActionDims; ++c, p += item) {
      const double v = item == 4 ? double(std::bit_cast<float>(static_cast<std::uint32_t>(load_le(p, 4))))
                                 : std::bit_cast<double>(load_le(p, 8));
      if (!std::isfinite(v))
        throw PolicyCodecError("\"actions\"[" + std::to_string(r) + "][" + std::to_string(c) + "] is " +
                               std::to_string(v) + ": the policy produced a non-finite action");
      chunk.actions[r][c] = v;
    }
  }
  if (const auto* timing = find(root, "server_timing"))
    if (const auto* infer = find(*timing, "infer_ms"))
      if (const auto ms = scalar_of(*infer)) chunk.infer_ms = *ms;
  return chunk;
}

nlohmann::json decode_metadata(std::string_view message) {
  const auto handle = parse_one(message, "the metadata frame");
  const auto& root = handle.get();
  if (root.type != msgpack::type::MAP)
    throw PolicyCodecError("the metadata frame is " + describe(root) +
                           ", not a map (openpi's metadata dict)");
  return to_json(root);
}

}  // namespace dh::policy
