#include "dh/rtde/client.hpp"

#include <algorithm>
#include <array>
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <functional>

#include "deadline_socket.hpp"
#include <optional>

namespace dh::rtde {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

struct Client::Io : DeadlineSocket {};

Client::Client() : io_(std::make_unique<Io>()) {}
Client::~Client() = default;

bool Client::connected() const { return io_->socket.is_open(); }

void Client::close() {
  io_->close();
  reader_ = PackageReader{};
}

void Client::fail(const std::string& why) {
  close();
  throw ClientError(why);
}

void Client::connect(const std::string& host, std::uint16_t port, std::chrono::milliseconds timeout) {
  close();
  bool refused = false;
  if (const auto why = io_->connect(host, port, timeout, refused))
    fail("connect: " + *why + (refused ? " (is the controller on and RTDE enabled?)" : ""));
  const std::string where = host + ":" + std::to_string(port);
  if (!accepted_reply_of(request_protocol_version(), "negotiate", timeout))
    fail("negotiate: " + where + " does not speak RTDE protocol version " + std::to_string(kProtocolVersion));
}

template <class Read>
auto Client::decoded(const char* step, Read&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const ProtocolError& e) {
    fail(std::string(step) + ": " + e.what());
  }
}

bool Client::accepted_reply_of(const Package& request, const char* step, std::chrono::milliseconds timeout) {
  const Package reply = exchange(request, step, timeout);
  return decoded(step, [&] { return accepted(reply, request.type); });
}

ControllerVersion Client::controller_version(std::chrono::milliseconds timeout) {
  const Package reply = exchange(get_urcontrol_version(), "controller version", timeout);
  return decoded("controller version", [&] { return urcontrol_version(reply); });
}

Recipe Client::setup_outputs(double frequency, const std::vector<std::string>& names,
                             std::chrono::milliseconds timeout) {
  const Package reply = exchange(rtde::setup_outputs(frequency, names), "setup outputs", timeout);
  return decoded("setup outputs", [&] { return recipe(reply, PackageType::SetupOutputs, names); });
}

Recipe Client::setup_inputs(const std::vector<std::string>& names, std::chrono::milliseconds timeout) {
  const Package reply = exchange(rtde::setup_inputs(names), "setup inputs", timeout);
  return decoded("setup inputs", [&] { return recipe(reply, PackageType::SetupInputs, names); });
}

void Client::start(std::chrono::milliseconds timeout) {
  if (!accepted_reply_of(request_start(), "start", timeout))
    fail("start: the controller refused to start the data exchange (a recipe not set up?)");
}

void Client::pause(std::chrono::milliseconds timeout) {
  if (!accepted_reply_of(request_pause(), "pause", timeout))
    fail("pause: the controller refused to pause the data exchange");
}

std::vector<Value> Client::receive(const Recipe& outputs, std::chrono::milliseconds timeout) {
  const Package p = next("receive", timeout);
  if (p.type != PackageType::DataPackage)
    fail("receive: a " + to_string(p.type) + " package where data was expected");
  return decoded("receive", [&] { return data_values(p, outputs); });
}

std::vector<Value> Client::receive_latest(const Recipe& outputs, std::chrono::milliseconds timeout) {
  std::vector<Value> v = receive(outputs, timeout);
  while (unread()) v = receive(outputs, timeout);
  return v;
}

bool Client::unread() {
  boost::system::error_code ec;
  return reader_.buffered() > 0 || io_->socket.available(ec) > 0;
}

void Client::send(const Recipe& inputs, const std::vector<Value>& values, std::chrono::milliseconds timeout) {
  write(data_package(inputs, values), "send", timeout);
}

Package Client::exchange(const Package& request, const char* step, std::chrono::milliseconds timeout) {
  // One deadline for the whole exchange: outputs streamed before the reply do not extend it.
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  write(request, step, timeout);
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    Package p = next(step, std::max(left, std::chrono::milliseconds(0)));
    if (p.type == request.type) return p;
    // Output data may still be on its way after a pause; anything else answers nothing we asked.
    if (p.type != PackageType::DataPackage)
      fail(std::string(step) + ": a " + to_string(p.type) + " package where " + to_string(request.type) +
           " was expected");
    // Past the deadline only what came before it is read: outputs stream on, but the reply is late.
    if (left.count() <= 0 && !unread())
      fail(std::string(step) + ": no answer from the controller within " + std::to_string(timeout.count()) +
           " ms");
  }
}

void Client::write(const Package& p, const char* step, std::chrono::milliseconds timeout) {
  if (!connected()) throw ClientError(std::string(step) + ": not connected");
  const std::vector<std::uint8_t> bytes = encode(p);
  boost::system::error_code ec;
  asio::async_write(io_->socket, asio::buffer(bytes),
                    [&](const boost::system::error_code& e, std::size_t) { ec = e; });
  if (!io_->run(timeout))
    fail(std::string(step) + ": the controller took no data within " + std::to_string(timeout.count()) +
         " ms");
  if (ec) fail(std::string(step) + ": " + ec.message());
}

Package Client::next(const char* step, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const std::optional<Package> p = decoded(step, [&] { return reader_.next(); });
    if (p) {
      if (p->type != PackageType::TextMessage) return *p;
      messages_.push_back(decoded(step, [&] { return text_message(*p); }));
      continue;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (!connected()) fail(std::string(step) + ": not connected");
    std::array<std::uint8_t, 4096> buffer;
    std::size_t got = 0;
    boost::system::error_code ec;
    io_->socket.async_read_some(asio::buffer(buffer), [&](const boost::system::error_code& e, std::size_t n) {
      ec = e;
      got = n;
    });
    if (!io_->run(std::max(left, std::chrono::milliseconds(0))))
      fail(std::string(step) + ": no answer from the controller within " + std::to_string(timeout.count()) +
           " ms");
    if (ec) fail(std::string(step) + ": the controller closed the connection (" + ec.message() + ")");
    reader_.feed(std::span(buffer.data(), got));
  }
}

void send_script(const std::string& host, std::uint16_t port, const std::string& script,
                 std::chrono::milliseconds timeout) {
  const std::string where = host + ":" + std::to_string(port);
  asio::io_context context;
  tcp::socket socket(context);
  boost::system::error_code ec;
  const auto endpoints = tcp::resolver(context).resolve(host, std::to_string(port), ec);
  if (ec) throw ClientError("send script: cannot resolve " + where + ": " + ec.message());
  bool sent = false;
  asio::async_connect(socket, endpoints, [&](const boost::system::error_code& e, const tcp::endpoint&) {
    if ((ec = e)) return;
    asio::async_write(socket, asio::buffer(script), [&](const boost::system::error_code& w, std::size_t) {
      ec = w;
      sent = !w;
    });
  });
  context.run_for(timeout);
  if (!sent)
    throw ClientError("send script: " + where + ": " +
                      (ec ? ec.message() : "no answer within " + std::to_string(timeout.count()) + " ms") +
                      " (is the controller's secondary interface reachable and in remote control?)");
  // A UR's secondary interface streams its state to every client: read it until the controller closes
  // or a moment has passed, so that closing does not reset the link under the script.
  socket.shutdown(tcp::socket::shutdown_send, ec);
  std::array<char, 4096> discard;
  std::function<void(const boost::system::error_code&, std::size_t)> drain =
      [&](const boost::system::error_code& e, std::size_t) {
        if (!e) socket.async_read_some(asio::buffer(discard), drain);
      };
  socket.async_read_some(asio::buffer(discard), drain);
  context.restart();
  context.run_for(std::chrono::milliseconds(100));
  socket.close(ec);
}

}  // namespace dh::rtde
