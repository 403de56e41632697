#include "dh/rtde/protocol.hpp"

#include <bit>
#include <cstring>
#include <sstream>

namespace dh::rtde {

namespace {

/// Big-endian writes of RTDE's fields.
class Writer {
 public:
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void u16(std::uint16_t v) { put(v); }
  void u32(std::uint32_t v) { put(v); }
  void u64(std::uint64_t v) { put(v); }
  void f64(double v) { put(std::bit_cast<std::uint64_t>(v)); }
  void text(const std::string& s) { bytes_.insert(bytes_.end(), s.begin(), s.end()); }
  std::vector<std::uint8_t> take() { return std::move(bytes_); }

 private:
  template <class T>
  void put(T v) {
    for (int shift = 8 * (static_cast<int>(sizeof(T)) - 1); shift >= 0; shift -= 8)
      bytes_.push_back(static_cast<std::uint8_t>(v >> shift));
  }
  std::vector<std::uint8_t> bytes_;
};

/// Big-endian reads with bounds: a short payload names the package and what was being read.
class Reader {
 public:
  Reader(const Package& p, const char* what) : p_(p), what_(what) {}
  std::uint8_t u8() { return static_cast<std::uint8_t>(get<1>()); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(get<2>()); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(get<4>()); }
  std::uint64_t u64() { return get<8>(); }
  double f64() { return std::bit_cast<double>(get<8>()); }
  std::string text(std::size_t n) {
    need(n);
    std::string s(p_.payload.begin() + static_cast<std::ptrdiff_t>(at_),
                  p_.payload.begin() + static_cast<std::ptrdiff_t>(at_ + n));
    at_ += n;
    return s;
  }
  std::string rest() { return text(p_.payload.size() - at_); }
  bool done() const { return at_ == p_.payload.size(); }

 private:
  void need(std::size_t n) const {
    if (at_ + n > p_.payload.size())
      throw ProtocolError(to_string(p_.type) + " package: " + what_ + " needs " + std::to_string(at_ + n) +
                          " payload bytes, it has " + std::to_string(p_.payload.size()));
  }
  template <std::size_t N>
  std::uint64_t get() {
    need(N);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < N; ++i) v = (v << 8) | p_.payload[at_ + i];
    at_ += N;
    return v;
  }
  const Package& p_;
  const char* what_;
  std::size_t at_ = 0;
};

void expect(const Package& p, PackageType want) {
  if (p.type != want)
    throw ProtocolError("expected a " + to_string(want) + " package, got " + to_string(p.type));
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) {
    if (n.empty() || n.find(',') != std::string::npos)
      throw ProtocolError("recipe field '" + n + "': a name is not empty and holds no comma");
    s += (s.empty() ? "" : ",") + n;
  }
  return s;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

template <class T, std::size_t N, class Get>
std::array<T, N> array_of(Get get) {
  std::array<T, N> a{};
  for (auto& x : a) x = get();
  return a;
}

}  // namespace

std::string to_string(PackageType t) {
  switch (t) {
    case PackageType::RequestProtocolVersion:
      return "REQUEST_PROTOCOL_VERSION";
    case PackageType::GetUrcontrolVersion:
      return "GET_URCONTROL_VERSION";
    case PackageType::TextMessage:
      return "TEXT_MESSAGE";
    case PackageType::DataPackage:
      return "DATA_PACKAGE";
    case PackageType::SetupOutputs:
      return "CONTROL_PACKAGE_SETUP_OUTPUTS";
    case PackageType::SetupInputs:
      return "CONTROL_PACKAGE_SETUP_INPUTS";
    case PackageType::Start:
      return "CONTROL_PACKAGE_START";
    case PackageType::Pause:
      return "CONTROL_PACKAGE_PAUSE";
  }
  char code[8];
  std::snprintf(code, sizeof code, "0x%02x", static_cast<unsigned>(t));
  return std::string("type ") + code;
}

const char* to_string(FieldType t) {
  switch (t) {
    case FieldType::Bool:
      return "BOOL";
    case FieldType::Uint8:
      return "UINT8";
    case FieldType::Uint32:
      return "UINT32";
    case FieldType::Int32:
      return "INT32";
    case FieldType::Uint64:
      return "UINT64";
    case FieldType::Double:
      return "DOUBLE";
    case FieldType::Vector3d:
      return "VECTOR3D";
    case FieldType::Vector6d:
      return "VECTOR6D";
    case FieldType::Vector6Int32:
      return "VECTOR6INT32";
    case FieldType::Vector6Uint32:
      return "VECTOR6UINT32";
  }
  return "?";
}

std::optional<FieldType> field_type(const std::string& name) {
  for (FieldType t : {FieldType::Bool, FieldType::Uint8, FieldType::Uint32, FieldType::Int32,
                      FieldType::Uint64, FieldType::Double, FieldType::Vector3d, FieldType::Vector6d,
                      FieldType::Vector6Int32, FieldType::Vector6Uint32})
    if (name == to_string(t)) return t;
  return std::nullopt;
}

std::size_t wire_bytes(FieldType t) {
  switch (t) {
    case FieldType::Bool:
    case FieldType::Uint8:
      return 1;
    case FieldType::Uint32:
    case FieldType::Int32:
      return 4;
    case FieldType::Uint64:
    case FieldType::Double:
      return 8;
    case FieldType::Vector3d:
      return 24;
    case FieldType::Vector6d:
      return 48;
    case FieldType::Vector6Int32:
    case FieldType::Vector6Uint32:
      return 24;
  }
  return 0;
}

FieldType type_of(const Value& v) {
  // The variant's alternatives are in FieldType's order.
  return static_cast<FieldType>(v.index());
}

std::vector<std::uint8_t> encode(const Package& p) {
  const std::size_t size = kHeaderBytes + p.payload.size();
  if (size > 0xffff)
    throw ProtocolError(to_string(p.type) + " package of " + std::to_string(size) +
                        " bytes: RTDE's size field holds at most 65535");
  Writer w;
  w.u16(static_cast<std::uint16_t>(size));
  w.u8(static_cast<std::uint8_t>(p.type));
  std::vector<std::uint8_t> out = w.take();
  out.insert(out.end(), p.payload.begin(), p.payload.end());
  return out;
}

void PackageReader::feed(std::span<const std::uint8_t> bytes) {
  // What was read is dropped once it is half the buffer, so a stream read mid-package keeps it bounded.
  if (at_ > 0 && 2 * at_ >= buffer_.size()) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(at_));
    at_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

std::optional<Package> PackageReader::next() {
  if (buffered() < kHeaderBytes) return std::nullopt;
  const std::size_t size = (std::size_t{buffer_[at_]} << 8) | buffer_[at_ + 1];
  if (size < kHeaderBytes)
    throw ProtocolError("an RTDE package claims " + std::to_string(size) +
                        " bytes, less than its own 3-byte header: the stream is not RTDE");
  if (buffered() < size) return std::nullopt;
  Package p{static_cast<PackageType>(buffer_[at_ + 2]),
            {buffer_.begin() + static_cast<std::ptrdiff_t>(at_ + kHeaderBytes),
             buffer_.begin() + static_cast<std::ptrdiff_t>(at_ + size)}};
  at_ += size;
  return p;
}

Package request_protocol_version(std::uint16_t version) {
  Writer w;
  w.u16(version);
  return {PackageType::RequestProtocolVersion, w.take()};
}

Package get_urcontrol_version() { return {PackageType::GetUrcontrolVersion, {}}; }

Package setup_outputs(double frequency, const std::vector<std::string>& names) {
  Writer w;
  w.f64(frequency);
  w.text(joined(names));
  return {PackageType::SetupOutputs, w.take()};
}

Package setup_inputs(const std::vector<std::string>& names) {
  Writer w;
  w.text(joined(names));
  return {PackageType::SetupInputs, w.take()};
}

Package request_start() { return {PackageType::Start, {}}; }
Package request_pause() { return {PackageType::Pause, {}}; }

bool accepted(const Package& reply, PackageType request) {
  expect(reply, request);
  Reader r(reply, "the accepted flag");
  return r.u8() != 0;
}

ControllerVersion urcontrol_version(const Package& reply) {
  expect(reply, PackageType::GetUrcontrolVersion);
  Reader r(reply, "the controller's version");
  ControllerVersion v;
  v.major = r.u32();
  v.minor = r.u32();
  v.bugfix = r.u32();
  v.build = r.u32();
  return v;
}

Recipe recipe(const Package& reply, PackageType request, const std::vector<std::string>& names) {
  expect(reply, request);
  Reader r(reply, "the recipe id");
  Recipe out;
  out.id = r.u8();
  const std::vector<std::string> types = split(r.rest());
  if (types.size() != names.size())
    throw ProtocolError(to_string(request) + " reply lists " + std::to_string(types.size()) + " types for " +
                        std::to_string(names.size()) + " requested fields");
  std::string refused;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto t = field_type(types[i]);
    if (!t) {
      refused += (refused.empty() ? "" : ", ") + names[i] + " (" + types[i] + ")";
      continue;
    }
    out.names.push_back(names[i]);
    out.types.push_back(*t);
  }
  if (!refused.empty())
    throw ProtocolError("the controller refused the " +
                        std::string(request == PackageType::SetupInputs ? "input" : "output") +
                        " recipe: " + refused +
                        "; NOT_FOUND is a name this controller does not serve, IN_USE an "
                        "input another client writes");
  return out;
}

TextMessage text_message(const Package& p) {
  expect(p, PackageType::TextMessage);
  Reader r(p, "the text message");
  TextMessage m;
  m.message = r.text(r.u8());
  m.source = r.text(r.u8());
  m.level = r.u8();
  return m;
}

Package data_package(const Recipe& recipe, const std::vector<Value>& values) {
  if (values.size() != recipe.types.size())
    throw ProtocolError("recipe " + std::to_string(recipe.id) + " has " +
                        std::to_string(recipe.types.size()) + " fields, " + std::to_string(values.size()) +
                        " values were given");
  Writer w;
  w.u8(recipe.id);
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (type_of(values[i]) != recipe.types[i])
      throw ProtocolError("recipe " + std::to_string(recipe.id) + " field " + recipe.names[i] + " is " +
                          to_string(recipe.types[i]) + ", the value is " + to_string(type_of(values[i])));
    std::visit(
        [&](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, bool>)
            w.u8(v ? 1 : 0);
          else if constexpr (std::is_same_v<T, std::uint8_t>)
            w.u8(v);
          else if constexpr (std::is_same_v<T, std::uint32_t>)
            w.u32(v);
          else if constexpr (std::is_same_v<T, std::int32_t>)
            w.u32(static_cast<std::uint32_t>(v));
          else if constexpr (std::is_same_v<T, std::uint64_t>)
            w.u64(v);
          else if constexpr (std::is_same_v<T, double>)
            w.f64(v);
          else if constexpr (std::is_same_v<T, std::array<double, 3>> ||
                             std::is_same_v<T, std::array<double, 6>>)
            for (double x : v) w.f64(x);
          else if constexpr (std::is_same_v<T, std::array<std::int32_t, 6>>)
            for (std::int32_t x : v) w.u32(static_cast<std::uint32_t>(x));
          else
            for (std::uint32_t x : v) w.u32(x);
        },
        values[i]);
  }
  return {PackageType::DataPackage, w.take()};
}

std::vector<Value> data_values(const Package& p, const Recipe& recipe) {
  expect(p, PackageType::DataPackage);
  Reader r(p, "a field of the recipe");
  const std::uint8_t id = r.u8();
  if (id != recipe.id)
    throw ProtocolError("a data package of recipe " + std::to_string(id) + " where recipe " +
                        std::to_string(recipe.id) + " was expected");
  std::vector<Value> out;
  for (FieldType t : recipe.types) {
    switch (t) {
      case FieldType::Bool:
        out.emplace_back(r.u8() != 0);
        break;
      case FieldType::Uint8:
        out.emplace_back(r.u8());
        break;
      case FieldType::Uint32:
        out.emplace_back(r.u32());
        break;
      case FieldType::Int32:
        out.emplace_back(static_cast<std::int32_t>(r.u32()));
        break;
      case FieldType::Uint64:
        out.emplace_back(r.u64());
        break;
      case FieldType::Double:
        out.emplace_back(r.f64());
        break;
      case FieldType::Vector3d:
        out.emplace_back(array_of<double, 3>([&] { return r.f64(); }));
        break;
      case FieldType::Vector6d:
        out.emplace_back(array_of<double, 6>([&] { return r.f64(); }));
        break;
      case FieldType::Vector6Int32:
        out.emplace_back(array_of<std::int32_t, 6>([&] { return static_cast<std::int32_t>(r.u32()); }));
        break;
      case FieldType::Vector6Uint32:
        out.emplace_back(array_of<std::uint32_t, 6>([&] { return r.u32(); }));
        break;
    }
  }
  if (!r.done())
    throw ProtocolError("a data package of recipe " + std::to_string(id) + " is longer than its fields");
  return out;
}

std::vector<std::string> setup_names(const Package& request, double* frequency) {
  if (request.type != PackageType::SetupOutputs && request.type != PackageType::SetupInputs)
    throw ProtocolError("expected a setup request, got " + to_string(request.type));
  Reader r(request, "the output frequency");
  if (request.type == PackageType::SetupOutputs) {
    const double f = r.f64();
    if (frequency) *frequency = f;
  }
  return split(r.rest());
}

Package setup_reply(PackageType request, std::uint8_t id,
                    const std::vector<std::optional<FieldType>>& types) {
  Writer w;
  w.u8(id);
  std::string list;
  for (const auto& t : types)
    list += (list.empty() ? "" : ",") + std::string(t ? to_string(*t) : "NOT_FOUND");
  w.text(list);
  return {request, w.take()};
}

Package accepted_reply(PackageType request, bool ok) {
  return {request, {static_cast<std::uint8_t>(ok ? 1 : 0)}};
}

Package urcontrol_version_reply(const ControllerVersion& v) {
  Writer w;
  w.u32(v.major);
  w.u32(v.minor);
  w.u32(v.bugfix);
  w.u32(v.build);
  return {PackageType::GetUrcontrolVersion, w.take()};
}

Package text_message_package(const TextMessage& m) {
  if (m.message.size() > 255 || m.source.size() > 255)
    throw ProtocolError("a text message or its source longer than 255 bytes does not fit RTDE's length byte");
  Writer w;
  w.u8(static_cast<std::uint8_t>(m.message.size()));
  w.text(m.message);
  w.u8(static_cast<std::uint8_t>(m.source.size()));
  w.text(m.source);
  w.u8(m.level);
  return {PackageType::TextMessage, w.take()};
}

}  // namespace dh::rtde
