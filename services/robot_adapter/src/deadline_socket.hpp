// A TCP connection whose every operation runs to a deadline (Boost.Asio, on the caller's thread): what the
// RTDE client and the gripper's client are built on.
#pragma once

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace dh::rtde {

struct DeadlineSocket {
  boost::asio::io_context context;
  boost::asio::ip::tcp::socket socket{context};

  /// Runs the operation started before it until it completes or `timeout` passes; on timeout the socket
  /// is closed (the operation then completes with an error) and false is returned. The deadline is
  /// declared only after a last look that finds nothing: a caller descheduled past its deadline on a
  /// loaded host finds what came meanwhile (run_for does not look once its deadline has passed).
  bool run(std::chrono::milliseconds timeout) {
    context.restart();
    context.run_for(timeout);
    if (context.stopped()) return true;
    context.poll();
    if (context.stopped()) return true;
    boost::system::error_code ignored;
    socket.close(ignored);
    context.restart();
    context.run();
    return false;
  }

  /// Closes the socket; cancelled operations' handlers run now, while what they write to still exists.
  void close() {
    boost::system::error_code ignored;
    socket.close(ignored);
    context.restart();
    context.run();
  }

  /// Connects to `host`:`port` (no delay on sends); nullopt, or why not: it cannot be resolved, does not
  /// answer within `timeout`, or refuses (then `refused` is set).
  std::optional<std::string> connect(const std::string& host, std::uint16_t port,
                                     std::chrono::milliseconds timeout, bool& refused) {
    const std::string where = host + ":" + std::to_string(port);
    refused = false;
    boost::system::error_code ec;
    boost::asio::ip::tcp::resolver resolver(context);
    const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
    if (ec) return "cannot resolve " + where + ": " + ec.message();
    boost::asio::async_connect(
        socket, endpoints,
        [&](const boost::system::error_code& e, const boost::asio::ip::tcp::endpoint&) { ec = e; });
    if (!run(timeout))
      return "no answer from " + where + " within " + std::to_string(timeout.count()) + " ms";
    if (ec) {
      refused = true;
      return where + ": " + ec.message();
    }
    socket.set_option(boost::asio::ip::tcp::no_delay(true), ec);
    return std::nullopt;
  }
};

}  // namespace dh::rtde
