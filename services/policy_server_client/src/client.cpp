// The only file that includes Boost.Beast / Asio. Every network operation is asynchronous on the client's
// own io_context and run until it completes or the call's deadline passes; a late operation is aborted by
// closing the socket, and the connection is dropped (the next call reconnects).
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <cctype>
#include <charconv>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "dh/policy/policy_server_client.hpp"

namespace dh::policy {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using Kind = PolicyServerErrorKind;

const char* to_string(PolicyServerErrorKind kind) {
  switch (kind) {
    case Kind::kInvalidUrl:
      return "invalid-url";
    case Kind::kUnreachable:
      return "unreachable";
    case Kind::kTimeout:
      return "timeout";
    case Kind::kServerError:
      return "server-error";
    case Kind::kClosed:
      return "closed";
    case Kind::kBadReply:
      return "bad-reply";
  }
  return "unknown";
}

PolicyServerError::PolicyServerError(PolicyServerErrorKind kind, std::string url, const std::string& message)
    : std::runtime_error("policy server " + url + ": " + message), kind_(kind), url_(std::move(url)) {}

namespace {

constexpr const char* kStartHint =
    "start the policy server (openpi: `uv run scripts/serve_policy.py --env LIBERO`, port 8000) or fix the "
    "URL";
// How long a text frame's close frame is waited for, and how long closing politely may take.
constexpr auto kCloseWait = std::chrono::milliseconds(500);
// Lines of a server traceback quoted in an error (then its last line, the exception itself).
constexpr int kTracebackLines = 12;

struct Url {
  std::string host;  // without brackets
  unsigned port = PolicyServerClient::kDefaultPort;
  std::string target = "/";
  std::string text;  // normalised
};

Url parse_url(std::string url) {
  const auto invalid = [&](const std::string& why) {
    return PolicyServerError(Kind::kInvalidUrl, url,
                             why + "; expected ws://host:port (openpi's server: ws://<host>:8000)");
  };
  while (!url.empty() && std::isspace(static_cast<unsigned char>(url.back()))) url.pop_back();
  while (!url.empty() && std::isspace(static_cast<unsigned char>(url.front()))) url.erase(url.begin());
  std::string rest = url;
  if (const auto scheme = rest.find("://"); scheme != std::string::npos) {
    const auto name = rest.substr(0, scheme);
    if (name != "ws")
      throw invalid("scheme '" + name +
                    "' is not supported (openpi serves plain, unencrypted WebSocket: ws://)");
    rest = rest.substr(scheme + 3);
  }
  Url u;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    u.target = rest.substr(slash);
    rest = rest.substr(0, slash);
  }
  std::string port;
  if (!rest.empty() && rest.front() == '[') {
    const auto close = rest.find(']');
    if (close == std::string::npos) throw invalid("unclosed '[' in the host");
    u.host = rest.substr(1, close - 1);
    const auto after = rest.substr(close + 1);
    if (!after.empty()) {
      if (after.front() != ':') throw invalid("unexpected '" + after + "' after the host");
      port = after.substr(1);
      if (port.empty()) throw invalid("empty port");
    }
  } else if (const auto colon = rest.find(':'); colon != std::string::npos) {
    if (rest.find(':', colon + 1) != std::string::npos) throw invalid("an IPv6 host must be in brackets");
    u.host = rest.substr(0, colon);
    port = rest.substr(colon + 1);
    if (port.empty()) throw invalid("empty port");
  } else {
    u.host = rest;
  }
  if (u.host.empty()) throw invalid("no host");
  if (!port.empty()) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (ec != std::errc() || end != port.data() + port.size() || value == 0 || value > 65535)
      throw invalid("port '" + port + "' is not a number in 1..65535");
    u.port = value;
  }
  const bool v6 = u.host.find(':') != std::string::npos;
  u.text = "ws://" + (v6 ? "[" + u.host + "]" : u.host) + ":" + std::to_string(u.port) + u.target;
  return u;
}

std::string ms_text(std::chrono::milliseconds t) { return std::to_string(t.count()) + " ms"; }

// The start of a Python traceback and its last line (the exception), for an error message.
std::string traceback_excerpt(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    auto end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  while (!lines.empty() && lines.back().find_first_not_of(" \t\r") == std::string::npos) lines.pop_back();
  std::string out;
  const int n = static_cast<int>(lines.size());
  for (int i = 0; i < std::min(n, kTracebackLines); ++i) out += "\n  | " + lines[i];
  if (n > kTracebackLines + 1) out += "\n  | … (" + std::to_string(n - kTracebackLines - 1) + " more lines)";
  if (n > kTracebackLines) out += "\n  | " + lines.back();
  return out.empty() ? "\n  | (empty text frame)" : out;
}

// What one asynchronous operation left behind; shared with its handler, which may run after a timeout.
struct OpState {
  bool done = false;
  beast::error_code ec;
  tcp::resolver::results_type resolved;
};

/// The completion handler of an operation that only reports its error code (and maybe a byte count or
/// an endpoint, ignored) into `st`.
auto completion(std::shared_ptr<OpState> st) {
  return [st = std::move(st)](beast::error_code ec, auto&&...) {
    st->ec = ec;
    st->done = true;
  };
}

}  // namespace

struct PolicyServerClient::Impl {
  Url url;
  std::chrono::milliseconds timeout;
  asio::io_context ioc;
  std::optional<tcp::resolver> resolver;
  std::unique_ptr<websocket::stream<tcp::socket>> ws;
  beast::flat_buffer buffer;
  nlohmann::json metadata = nlohmann::json::object();
  bool used = false;  // the open connection has carried a request
  std::size_t connections = 0;

  Impl(std::string u, std::chrono::milliseconds t) : url(parse_url(std::move(u))), timeout(t) {}

  [[noreturn]] void fail(Kind kind, const std::string& what) {
    throw PolicyServerError(kind, url.text, what);
  }

  // Closes the socket at once: pending operations end with operation_aborted.
  void abort_io() {
    beast::error_code ignored;
    if (resolver) resolver->cancel();
    if (ws) beast::get_lowest_layer(*ws).close(ignored);
  }

  void drop() {
    abort_io();
    if (ws) {
      ioc.restart();
      ioc.run_for(kCloseWait);  // let aborted handlers finish before the stream goes
    }
    ws.reset();
    resolver.reset();
    used = false;
  }

  // Runs the operation `start` begins (handing it a completion handler) until it completes or `deadline`
  // passes. Returns its error code, or nullopt on the deadline (the socket is then closed).
  template <class Start>
  std::optional<beast::error_code> await(Start&& start, Clock::time_point deadline,
                                         std::shared_ptr<OpState> st = std::make_shared<OpState>()) {
    ioc.restart();
    start(st);
    while (!st->done) {
      const auto now = Clock::now();
      if (now >= deadline) break;
      if (ioc.run_one_for(deadline - now) == 0 && ioc.stopped()) break;
    }
    if (st->done) return st->ec;
    abort_io();
    ioc.restart();
    ioc.run_for(kCloseWait);
    return std::nullopt;
  }

  // Reads one message. nullopt on the deadline.
  std::optional<beast::error_code> read(Clock::time_point deadline) {
    buffer.clear();
    return await(
        [this](std::shared_ptr<OpState> st) {
          ws->async_read(buffer, completion(st));
        },
        deadline);
  }

  std::string payload() const { return beast::buffers_to_string(buffer.data()); }

  std::string close_text() const {
    const auto& r = ws->reason();
    return "code " + std::to_string(r.code) + (r.reason.empty() ? "" : " \"" + std::string(r.reason) + "\"");
  }

  // The server sent a text frame: its traceback. Waits briefly for the close that follows, then fails.
  [[noreturn]] void fail_with_traceback(const std::string& when, Clock::time_point deadline) {
    const std::string traceback = payload();
    std::string closing;
    const auto wait = std::min(deadline, Clock::now() + kCloseWait);
    if (const auto ec = read(wait); ec && *ec == websocket::error::closed)
      closing = ", closed with " + close_text();
    drop();
    fail(Kind::kServerError, "the server failed " + when + " and sent its traceback" + closing + ":" +
                                 traceback_excerpt(traceback) +
                                 "\n(see the server's log; the next call reconnects)");
  }

  void connect(Clock::time_point deadline) {
    drop();
    const std::string where = url.host + ":" + std::to_string(url.port);
    const auto late = [&](const std::string& stage, const std::string& hint) {
      fail(Kind::kTimeout, "no " + stage + " within the timeout of " + ms_text(timeout) + "; " + hint);
    };
    // Addresses: a numeric host needs no resolver.
    std::vector<tcp::endpoint> endpoints;
    beast::error_code ec;
    const auto address = asio::ip::make_address(url.host, ec);
    if (!ec) {
      endpoints.emplace_back(address, static_cast<unsigned short>(url.port));
    } else {
      resolver.emplace(ioc);
      auto st = std::make_shared<OpState>();
      const auto r = await(
          [this](std::shared_ptr<OpState> s) {
            resolver->async_resolve(url.host, std::to_string(url.port),
                                    [s](beast::error_code e, tcp::resolver::results_type results) {
                                      s->ec = e;
                                      s->resolved = std::move(results);
                                      s->done = true;
                                    });
          },
          deadline, st);
      if (!r) late("address for host '" + url.host + "'", "check the name and the DNS, or use an IP address");
      if (*r)
        fail(Kind::kUnreachable,
             "cannot resolve host '" + url.host + "' (" + r->message() + "); fix the URL");
      for (const auto& e : st->resolved) endpoints.push_back(e.endpoint());
      resolver.reset();
    }

    ws = std::make_unique<websocket::stream<tcp::socket>>(ioc);
    const auto c = await(
        [this, &endpoints](std::shared_ptr<OpState> st) {
          asio::async_connect(beast::get_lowest_layer(*ws), endpoints, completion(st));
        },
        deadline);
    if (!c) {
      drop();
      late("TCP connection to " + where,
           "check that the host is reachable and the port open (a firewall may drop the packets), or raise "
           "the "
           "timeout");
    }
    if (*c) {
      drop();
      if (*c == asio::error::connection_refused)
        fail(Kind::kUnreachable, "connection refused: nothing listens on " + where + "; " + kStartHint);
      fail(Kind::kUnreachable, "cannot connect to " + where + " (" + c->message() + "); " + kStartHint);
    }
    beast::get_lowest_layer(*ws).set_option(tcp::no_delay(true), ec);

    // openpi's server: compression=None (Beast offers none by default), max_size=None.
    ws->read_message_max(0);
    ws->auto_fragment(false);
    ws->set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
      req.set(beast::http::field::user_agent, "dynaharness-policy-server-client");
    }));
    websocket::response_type response;
    const std::string host_header = url.text.substr(5, url.text.size() - 5 - (url.target.size()));
    const auto h = await(
        [this, &response, &host_header](std::shared_ptr<OpState> st) {
          ws->async_handshake(response, host_header, url.target, completion(st));
        },
        deadline);
    if (!h) {
      drop();
      late("WebSocket handshake with " + where,
           "something accepts connections on this port but does not answer as a WebSocket server: is it the "
           "policy "
           "server?");
    }
    if (*h) {
      drop();
      if (*h == websocket::error::upgrade_declined || response.result_int() != 0)
        fail(Kind::kBadReply, "the server at " + where + " declined the WebSocket upgrade (HTTP " +
                                  std::to_string(response.result_int()) + " " +
                                  std::string(response.reason()) +
                                  "); is this the policy server's port and path?");
      fail(Kind::kClosed, "the WebSocket handshake with " + where + " failed (" + h->message() +
                              "); is this an openpi policy server?");
    }

    // The first frame: msgpack(metadata).
    const auto m = read(deadline);
    if (!m) {
      drop();
      late("metadata frame",
           "the server accepted the WebSocket but sent nothing; an openpi policy server sends its metadata "
           "at once: "
           "is this one? (or raise the timeout)");
    }
    if (*m) {
      const std::string how = *m == websocket::error::closed
                                  ? "closed the connection (" + close_text() + ")"
                                  : "dropped the connection (" + m->message() + ")";
      drop();
      fail(Kind::kClosed, "the server " + how + " before sending its metadata; see the server's log");
    }
    if (ws->got_text()) fail_with_traceback("before sending its metadata", deadline);
    try {
      metadata = decode_metadata(payload());
    } catch (const PolicyCodecError& e) {
      drop();
      fail(Kind::kBadReply,
           std::string(e.what()) + "; is this an openpi policy server (it sends msgpack metadata first)?");
    }
    ++connections;
    used = false;
  }

  ActionChunk infer(const std::string& request, Clock::time_point start, Clock::time_point deadline) {
    for (int attempt = 0;; ++attempt) {
      if (!ws) connect(deadline);
      // A connection that served requests before may have been closed by the server meanwhile (restart,
      // idle keepalive): such a failure before any reply is retried once on a new connection.
      const bool may_retry = used && attempt == 0;
      used = true;
      ws->binary(true);
      const auto w = await(
          [this, &request](std::shared_ptr<OpState> st) {
            ws->async_write(asio::buffer(request), completion(st));
          },
          deadline);
      if (!w) {
        drop();
        fail(Kind::kTimeout, "could not send the observation (" + std::to_string(request.size()) +
                                 " bytes) within the timeout of " + ms_text(timeout) +
                                 "; the network or the server is stalled (the next call reconnects)");
      }
      if (*w) {
        drop();
        if (may_retry) continue;
        fail(Kind::kClosed, "the connection was lost while sending the observation (" + w->message() +
                                "); the next call reconnects");
      }

      const auto r = read(deadline);
      if (!r) {
        drop();
        fail(Kind::kTimeout,
             "no reply within the timeout of " + ms_text(timeout) +
                 " (the server may still be computing: openpi's first inference compiles the "
                 "model and can take much longer; raise the timeout or check the server's log); "
                 "the connection was closed and the next call reconnects");
      }
      if (*r) {
        const bool closed = *r == websocket::error::closed;
        const std::string how = closed ? "closed the connection (" + close_text() + ")"
                                       : "dropped the connection (" + r->message() + ")";
        drop();
        if (may_retry) continue;
        fail(Kind::kClosed,
             "the server " + how +
                 " instead of replying to the observation; see the server's log (the next call "
                 "reconnects)");
      }
      if (ws->got_text()) fail_with_traceback("on the observation", deadline);
      try {
        auto chunk = decode_action_chunk(payload());
        chunk.round_trip_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        return chunk;
      } catch (const PolicyCodecError& e) {
        fail(Kind::kBadReply,
             std::string(e.what()) +
                 "; is this an openpi policy server serving a LIBERO config (e.g. pi05_libero)?");
      }
    }
  }

  void close_politely() {
    if (!ws) return;
    const auto deadline = Clock::now() + std::min<Clock::duration>(timeout, kCloseWait);
    await(
        [this](std::shared_ptr<OpState> st) {
          ws->async_close(websocket::close_code::normal, completion(st));
        },
        deadline);
    drop();
  }
};

PolicyServerClient::PolicyServerClient(std::string url, std::chrono::milliseconds timeout)
    : impl_(std::make_unique<Impl>(std::move(url), timeout)) {
  if (timeout.count() <= 0)
    throw PolicyServerError(Kind::kInvalidUrl, impl_->url.text,
                            "the timeout must be positive, not " + ms_text(timeout));
}

PolicyServerClient::~PolicyServerClient() {
  if (!impl_) return;
  try {
    impl_->close_politely();
  } catch (...) {  // a destructor does not throw; the socket is closed either way
  }
}

PolicyServerClient::PolicyServerClient(PolicyServerClient&&) noexcept = default;
PolicyServerClient& PolicyServerClient::operator=(PolicyServerClient&&) noexcept = default;

void PolicyServerClient::connect() {
  if (!impl_->ws) impl_->connect(Clock::now() + impl_->timeout);
}

bool PolicyServerClient::connected() const { return impl_->ws != nullptr; }

void PolicyServerClient::close() { impl_->close_politely(); }

const nlohmann::json& PolicyServerClient::metadata() const { return impl_->metadata; }

ActionChunk PolicyServerClient::infer(const PolicyQuery& query) {
  const auto start = Clock::now();
  const auto deadline = start + impl_->timeout;
  const auto fitted = [](const CameraImage& image) {
    return image.width == kOpenpiImageSide && image.height == kOpenpiImageSide ? image
                                                                               : resize_with_pad(image);
  };
  std::string request;
  if (query.agent_view.width == kOpenpiImageSide && query.agent_view.height == kOpenpiImageSide &&
      query.wrist.width == kOpenpiImageSide && query.wrist.height == kOpenpiImageSide) {
    request = encode_observation(query);
  } else {
    PolicyQuery q = query;
    q.agent_view = fitted(query.agent_view);
    q.wrist = fitted(query.wrist);
    request = encode_observation(q);
  }
  return impl_->infer(request, start, deadline);
}

const std::string& PolicyServerClient::url() const { return impl_->url.text; }
std::chrono::milliseconds PolicyServerClient::timeout() const { return impl_->timeout; }
std::size_t PolicyServerClient::connections_made() const { return impl_->connections; }

}  // namespace dh::policy
