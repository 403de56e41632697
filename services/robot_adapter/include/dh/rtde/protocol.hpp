// UR's Real-Time Data Exchange (RTDE) protocol, as bytes: packages, recipes and data packages (issue 19).
// Written from UR's published layout (docs/ur-rtde.md, with its sources): TCP port 30004, big-endian
// fields, each package a uint16 size (header included) and a uint8 type, then its payload. This file
// knows the wire only; the client that speaks it to a controller (and the test controller that answers
// it) build on it. Protocol version 2 throughout: its output setup carries a frequency and its data
// packages a recipe id.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace dh::rtde {

inline constexpr std::uint16_t kPort = 30004;
inline constexpr std::uint16_t kProtocolVersion = 2;
inline constexpr std::size_t kHeaderBytes = 3;

/// Bytes that are not RTDE, or not what the exchange expects; what() names the package and the field.
struct ProtocolError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class PackageType : std::uint8_t {
  RequestProtocolVersion = 'V',
  GetUrcontrolVersion = 'v',
  TextMessage = 'M',
  DataPackage = 'U',
  SetupOutputs = 'O',
  SetupInputs = 'I',
  Start = 'S',
  Pause = 'P',
};
/// "REQUEST_PROTOCOL_VERSION", ...; "type 0x.." for a code RTDE does not define.
std::string to_string(PackageType t);

enum class FieldType {
  Bool,
  Uint8,
  Uint32,
  Int32,
  Uint64,
  Double,
  Vector3d,
  Vector6d,
  Vector6Int32,
  Vector6Uint32
};
/// The name the controller uses in a setup reply ("VECTOR6D", ...).
const char* to_string(FieldType t);
/// The type named in a setup reply; nullopt for NOT_FOUND, IN_USE or anything else.
std::optional<FieldType> field_type(const std::string& name);
std::size_t wire_bytes(FieldType t);

using Value = std::variant<bool, std::uint8_t, std::uint32_t, std::int32_t, std::uint64_t, double,
                           std::array<double, 3>, std::array<double, 6>, std::array<std::int32_t, 6>,
                           std::array<std::uint32_t, 6>>;
/// The field type a value is sent as.
FieldType type_of(const Value& v);

struct Package {
  PackageType type;
  std::vector<std::uint8_t> payload;
};

/// The package's bytes on the wire: size, type, payload. Throws ProtocolError for a payload too long
/// for the 16-bit size.
std::vector<std::uint8_t> encode(const Package& p);

/// Cuts a TCP byte stream into packages: feed it what arrived, take what is complete.
class PackageReader {
 public:
  void feed(std::span<const std::uint8_t> bytes);
  /// The next complete package, or nullopt until more bytes come. Throws ProtocolError for a size below
  /// the header's (the stream is then not RTDE, and nothing after it can be trusted).
  std::optional<Package> next();
  std::size_t buffered() const { return buffer_.size() - at_; }

 private:
  std::vector<std::uint8_t> buffer_;
  std::size_t at_ = 0;
};

// Requests a client sends.
Package request_protocol_version(std::uint16_t version = kProtocolVersion);
Package get_urcontrol_version();
/// Output recipe: the names the controller is to send, at `frequency` Hz.
Package setup_outputs(double frequency, const std::vector<std::string>& names);
/// Input recipe: the names the client will write.
Package setup_inputs(const std::vector<std::string>& names);
Package request_start();
Package request_pause();

/// A recipe the controller accepted: its id and each field's name and type.
struct Recipe {
  std::uint8_t id = 0;
  std::vector<std::string> names;
  std::vector<FieldType> types;
};

// Replies a client reads. Each throws ProtocolError for a package of another type or a short payload.
bool accepted(const Package& reply, PackageType request);  ///< V, S, P: uint8 accepted
struct ControllerVersion {
  std::uint32_t major = 0, minor = 0, bugfix = 0, build = 0;
};
ControllerVersion urcontrol_version(const Package& reply);
/// A setup reply (O or I) to the request for `names`. Throws ProtocolError naming every field the
/// controller answered NOT_FOUND or IN_USE, and for a type list that does not match the names.
Recipe recipe(const Package& reply, PackageType request, const std::vector<std::string>& names);
struct TextMessage {
  std::string message, source;
  std::uint8_t level = 0;  ///< 0 exception, 1 error, 2 warning, 3 info
};
TextMessage text_message(const Package& p);

/// A data package of `recipe`: its id, then each value in the recipe's order and type. Throws
/// ProtocolError for a value count or type that is not the recipe's.
Package data_package(const Recipe& recipe, const std::vector<Value>& values);
/// The values of a data package of `recipe`. Throws ProtocolError for another recipe id or a payload
/// whose length is not the recipe's.
std::vector<Value> data_values(const Package& p, const Recipe& recipe);

// The controller's side, for the test controller.
/// The names of a setup request (O: after its frequency, which goes to `frequency` when given).
std::vector<std::string> setup_names(const Package& request, double* frequency = nullptr);
/// A setup reply: the recipe id, then each type's name (NOT_FOUND for a name not served).
Package setup_reply(PackageType request, std::uint8_t id, const std::vector<std::optional<FieldType>>& types);
Package accepted_reply(PackageType request, bool ok);
Package urcontrol_version_reply(const ControllerVersion& v);
Package text_message_package(const TextMessage& m);

}  // namespace dh::rtde
