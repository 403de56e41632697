// Client of an openpi policy server (openpi's scripts/serve_policy.py: pi0 / pi0.5 behind a WebSocket), the
// `policy-server` backend of the vla_act capability. The protocol: ws://host:port (default port 8000), no
// compression, no message size limit; on connect the server sends one binary frame, msgpack(metadata);
// then each binary frame msgpack(observation) is answered by one binary frame msgpack(action dict) (see
// openpi_codec.hpp). On a failure the server sends its Python traceback as a text frame and closes the
// connection with 1011.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>

#include "dh/policy/openpi_codec.hpp"
#include "dh/policy/openpi_types.hpp"
#include "dh/policy/resize_with_pad.hpp"

namespace dh::policy {

enum class PolicyServerErrorKind {
  kInvalidUrl,   ///< the URL is not ws://host[:port][/path]
  kUnreachable,  ///< the name does not resolve, the connection is refused or the network is unreachable
  kTimeout,      ///< no connection, metadata or reply within the client's timeout
  kServerError,  ///< the server failed on the request: traceback text frame, close 1011
  kClosed,       ///< the server closed or dropped the connection without a reply
  kBadReply,     ///< a frame that is not what the protocol says (not msgpack, no "actions", wrong shape …)
};
const char* to_string(PolicyServerErrorKind kind);

/// Why a call to the policy server failed. what() names the URL, what went wrong and what to do.
class PolicyServerError : public std::runtime_error {
 public:
  PolicyServerError(PolicyServerErrorKind kind, std::string url, const std::string& message);
  PolicyServerErrorKind kind() const { return kind_; }
  const std::string& url() const { return url_; }

 private:
  PolicyServerErrorKind kind_;
  std::string url_;
};

/// One connection to one policy server, made on first use and made again on the next call after it was
/// lost (server closed it, error, timeout). Every call returns or throws within the timeout (plus a few
/// milliseconds). Movable (a moved-from client may only be destroyed or assigned to), not copyable; not to
/// be shared between threads.
class PolicyServerClient {
 public:
  static constexpr unsigned kDefaultPort = 8000;

  /// `url`: "ws://host:port/path", "ws://host" (port 8000), or "host:port" / "host" as openpi's own client
  /// accepts; IPv6 literals in brackets. PolicyServerError (kInvalidUrl) when it cannot be parsed or
  /// names another scheme (wss://, http://). Does not connect.
  explicit PolicyServerClient(std::string url,
                              std::chrono::milliseconds timeout = std::chrono::milliseconds(30'000));
  ~PolicyServerClient();
  PolicyServerClient(PolicyServerClient&&) noexcept;
  PolicyServerClient& operator=(PolicyServerClient&&) noexcept;
  PolicyServerClient(const PolicyServerClient&) = delete;
  PolicyServerClient& operator=(const PolicyServerClient&) = delete;

  /// Connects (TCP, WebSocket handshake, the metadata frame) unless connected; PolicyServerError on
  /// failure, within the timeout.
  void connect();
  bool connected() const;
  /// Closes the connection politely (close frame, bounded by the timeout); the next call reconnects.
  void close();

  /// The metadata the server sent on the latest connection (a JSON object; empty before the first).
  const nlohmann::json& metadata() const;

  /// Sends `query` and returns the server's action chunk. Images of another size than 224 × 224 are first
  /// resized with padding (resize_with_pad). The whole call (connecting when needed, sending, waiting for
  /// the reply) is bounded by the timeout. A connection that had already served a request and turns out
  /// to be closed when used (the server restarted, or dropped it while idle) is replaced and the request
  /// sent once more within the same deadline. std::invalid_argument for an image whose byte count is not
  /// width × height × 3; PolicyServerError for everything the server or the network does.
  ActionChunk infer(const PolicyQuery& query);

  const std::string& url() const;  ///< normalised: ws://host:port/path
  std::chrono::milliseconds timeout() const;
  std::size_t connections_made() const;  ///< connections opened so far (reconnections included)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dh::policy
