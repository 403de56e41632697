// An RTDE client over TCP (Boost.Asio, kept inside client.cpp): a session with a UR controller, or with
// the test controller. Every call has a deadline; a controller that does not answer in time, refuses a
// step or closes the connection ends the call with ClientError naming the step, and the session is then
// closed (a caller reconnects and sets up again).
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "dh/rtde/protocol.hpp"

namespace dh::rtde {

/// A session that cannot go on: what() names the step (connect, negotiate, setup, start, receive, send)
/// and why.
struct ClientError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Client {
 public:
  Client();
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// Connects to `host`:`port` and agrees on protocol version 2.
  void connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout);
  ControllerVersion controller_version(std::chrono::milliseconds timeout);
  /// The output recipe (`names` at `frequency` Hz) and an input recipe; each throws ClientError naming
  /// the fields the controller refused.
  Recipe setup_outputs(double frequency, const std::vector<std::string>& names,
                       std::chrono::milliseconds timeout);
  Recipe setup_inputs(const std::vector<std::string>& names, std::chrono::milliseconds timeout);
  void start(std::chrono::milliseconds timeout);
  void pause(std::chrono::milliseconds timeout);
  /// The next output data package's values. Text messages that come first are kept (messages()).
  std::vector<Value> receive(const Recipe& outputs, std::chrono::milliseconds timeout);
  /// The newest output data package: the next one, then every one already queued behind it (outputs
  /// stream on while nobody reads, so the next one may be old).
  std::vector<Value> receive_latest(const Recipe& outputs, std::chrono::milliseconds timeout);
  /// Writes an input data package.
  void send(const Recipe& inputs, const std::vector<Value>& values, std::chrono::milliseconds timeout);
  void close();
  bool connected() const;
  /// Text messages the controller sent, oldest first.
  const std::vector<TextMessage>& messages() const { return messages_; }

 private:
  struct Io;
  /// The next package that is not a text message; ClientError (closing) on timeout or a closed link.
  Package next(const char* step, std::chrono::milliseconds timeout);
  void write(const Package& p, const char* step, std::chrono::milliseconds timeout);
  /// Whether bytes came that are not read yet (in the package reader or the socket).
  bool unread();
  /// Sends `request` and returns the reply of its type, all within `timeout`.
  Package exchange(const Package& request, const char* step, std::chrono::milliseconds timeout);
  /// The accepted flag of the reply to `request`.
  bool accepted_reply_of(const Package& request, const char* step, std::chrono::milliseconds timeout);
  [[noreturn]] void fail(const std::string& why);
  /// What `read` makes of the controller's bytes; a ProtocolError ends the session as `step`'s ClientError.
  template <class Read>
  auto decoded(const char* step, Read&& read) -> decltype(read());

  std::unique_ptr<Io> io_;
  PackageReader reader_;
  std::vector<TextMessage> messages_;
};

/// Sends a URScript program to the controller's secondary interface (`port`, 30002 on a UR) and closes:
/// the controller runs it. Throws ClientError naming the step (connect, send) within `timeout`.
void send_script(const std::string& host, std::uint16_t port, const std::string& script,
                 std::chrono::milliseconds timeout);

}  // namespace dh::rtde
