// The view's web server (Boost.Beast, one thread): the page and its scripts from the repository's web
// folder (nothing from elsewhere), a JSON API, and a WebSocket that pushes the live snapshot to every
// client at a fixed period. Read-only: every route is a GET. With a token, every request must carry it
// (`?token=T`, or `Authorization: Bearer T`), else 401. A client that reads nothing is never waited for:
// while its last push is still being written, newer ones are skipped for it, so memory stays bounded.
// An API call other than the snapshot runs on a thread of its own (the handler must allow that), so a
// slow one (a film) does not hold up the pushes.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

namespace dh::view {

struct Response {
  unsigned status = 200;
  std::string content_type = "application/json";
  std::string body;
};

struct ServerOptions {
  std::string bind = "127.0.0.1";
  std::uint16_t port = 8642;  ///< 0: any free port (port() says which)
  std::string token;          ///< empty: no token asked for
  std::filesystem::path web_dir;
  std::chrono::milliseconds push_period{250};
};

struct Handlers {
  std::function<nlohmann::json()> snapshot;  ///< the live panes' state, called on the server's thread
  /// GET /api/<name>?<query> (name without "/api/"), e.g. "episode", {"evidence": path}.
  std::function<Response(const std::string& name, const std::map<std::string, std::string>& query)> api;
};

class Server {
 public:
  /// Binds and starts serving. Throws std::runtime_error naming the address when it cannot bind, and
  /// std::invalid_argument when the web folder has no index.html.
  Server(ServerOptions options, Handlers handlers);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  std::uint16_t port() const;
  /// WebSocket clients connected now, and pushes skipped because a client had not taken the last one.
  std::size_t clients() const;
  std::uint64_t skipped_pushes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "a%20b" -> "a b"; '+' is a space.
std::string url_decode(const std::string& s);
/// The query of a request target ("/x?a=1&b=2") as a map, decoded.
std::map<std::string, std::string> query_of(const std::string& target);

}  // namespace dh::view
