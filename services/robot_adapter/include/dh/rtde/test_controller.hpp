// The RTDE test controller: a test double for the metal, not a robot. It speaks RTDE on loopback as a UR
// controller does (docs/ur-rtde.md) for the adapter's tests and the cell's dry run: ControllerCore holds
// the session's rules (versions, recipes, start and pause, input data), TestController serves it over
// TCP on 127.0.0.1 and streams the outputs at the recipe's frequency; a second port stands for the
// secondary interface (30002), where a client sends a URScript program and closes. What the outputs say
// and what a program does come from its caller: SimulatedController (simulated_ur.hpp) backs it with the
// UR7e in MuJoCo.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dh/rtde/protocol.hpp"

namespace dh::rtde {

/// What a controller serves: the outputs it can send and the inputs a client may write, by name.
struct ControllerModel {
  std::map<std::string, FieldType> outputs, inputs;
  ControllerVersion version{5, 15, 0, 0};
};

/// One session's rules, without sockets: each request package gives its replies.
class ControllerCore {
 public:
  explicit ControllerCore(ControllerModel model) : model_(std::move(model)) {}
  /// The replies to `p`. A data package gives none (its values are the inputs now); one of an unknown
  /// recipe, or a request out of order, gives an error text message naming it.
  std::vector<Package> on_package(const Package& p);
  bool streaming() const { return streaming_; }
  double frequency() const { return frequency_; }
  /// The output recipe the client set up, or null.
  const Recipe* output_recipe() const { return outputs_ ? &*outputs_ : nullptr; }
  /// The inputs written last, by name.
  const std::map<std::string, Value>& inputs() const { return inputs_; }

 private:
  static Package error(const std::string& message);
  ControllerModel model_;
  std::optional<Recipe> outputs_;
  std::map<std::uint8_t, Recipe> input_recipes_;
  std::map<std::string, Value> inputs_;
  double frequency_ = 0;
  bool streaming_ = false, negotiated_ = false;
  std::uint8_t next_id_ = 1;
};

/// ControllerCore served on 127.0.0.1, one client at a time, on a thread of its own.
class TestController {
 public:
  /// The values of the named output fields, in their order, for one data package: one moment's outputs.
  using Read = std::function<std::vector<Value>(const std::vector<std::string>& names)>;

  /// Listens on `port` and `script_port` (0: one the system picks); `read` gives each data package's
  /// values, `on_script` each script received whole (both on the controller's thread).
  TestController(ControllerModel model, Read read, std::function<void(const std::string&)> on_script = {},
                 std::uint16_t port = 0, std::uint16_t script_port = 0);
  ~TestController();
  TestController(const TestController&) = delete;
  TestController& operator=(const TestController&) = delete;

  std::uint16_t port() const { return port_; }
  /// The secondary interface's stand-in: a script is the bytes a client sends before it closes.
  std::uint16_t script_port() const { return script_port_; }
  /// The inputs the client wrote last, by name.
  std::map<std::string, Value> inputs() const;
  /// Output data packages sent in this session.
  std::size_t outputs_sent() const;
  /// Fault injection: while set, requests are read and not answered, and no output is sent.
  void set_silent(bool silent);
  /// Closes the client's connection (a cable pulled); the next client is accepted.
  void drop_client();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint16_t port_ = 0, script_port_ = 0;
};

}  // namespace dh::rtde
