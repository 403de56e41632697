#include "dh/view/server.hpp"

#include <atomic>
#include <condition_variable>
#include <cctype>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

namespace dh::view {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

std::string url_decode(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
               std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

std::map<std::string, std::string> query_of(const std::string& target) {
  std::map<std::string, std::string> q;
  const auto mark = target.find('?');
  if (mark == std::string::npos) return q;
  std::stringstream parts(target.substr(mark + 1));
  for (std::string kv; std::getline(parts, kv, '&');) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) q[url_decode(kv)] = "";
    else q[url_decode(kv.substr(0, eq))] = url_decode(kv.substr(eq + 1));
  }
  return q;
}

namespace {

std::string content_type(const std::filesystem::path& file) {
  const std::string ext = file.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".png") return "image/png";
  return "application/octet-stream";
}

std::string json_error(const std::string& what) { return nlohmann::json{{"error", what}}.dump(); }

/// API calls running at once at most (a film re-runs an episode and renders it).
constexpr int kMaxWorking = 4;

// A pushed client: one write in flight at most; what comes meanwhile is skipped.
class Socket : public std::enable_shared_from_this<Socket> {
 public:
  Socket(tcp::socket s, std::atomic<std::uint64_t>& skipped) : ws_(std::move(s)), skipped_(skipped) {}

  // The upgrade request stays alive until the handshake is answered.
  void accept(std::shared_ptr<http::request<http::string_body>> req, std::function<void()> on_close) {
    on_close_ = std::move(on_close);
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.async_accept(*req, [self = shared_from_this(), req](beast::error_code ec) {
      if (ec) return self->close();
      self->open_ = true;
      self->read();
    });
  }

  void push(std::shared_ptr<const std::string> text) {
    if (!open_) return;
    if (writing_) {
      ++skipped_;
      return;
    }
    writing_ = true;
    out_ = std::move(text);
    ws_.text(true);
    ws_.async_write(asio::buffer(*out_), [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->writing_ = false;
      if (ec) self->close();
    });
  }

 private:
  // Reads (and drops) what the client sends, so pings and the close handshake are answered.
  void read() {
    ws_.async_read(in_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->in_.clear();
      self->read();
    });
  }
  void close() {
    open_ = false;
    if (on_close_) std::exchange(on_close_, nullptr)();
  }

  websocket::stream<tcp::socket> ws_;
  beast::flat_buffer in_;
  std::shared_ptr<const std::string> out_;
  bool writing_ = false, open_ = false;
  std::atomic<std::uint64_t>& skipped_;
  std::function<void()> on_close_;
};

}  // namespace

// Handlers capture the Impl by pointer: it outlives every one of them (the destructor stops the context and
// joins its thread before the Impl goes; pending handlers are destroyed with the context, unrun).
struct Server::Impl {
  ServerOptions o;
  Handlers h;
  asio::io_context ioc;
  tcp::acceptor acceptor{ioc};
  asio::steady_timer timer{ioc};
  std::vector<std::weak_ptr<Socket>> sockets;
  std::atomic<std::size_t> clients{0};
  std::atomic<std::uint64_t> skipped{0};
  std::thread thread;
  std::uint16_t port = 0;  ///< bound, read before the thread starts
  std::mutex work_mutex;
  std::condition_variable work_done;
  int working = 0;  ///< API calls running on threads of their own (work_mutex)

  bool authorised(const http::request<http::string_body>& req) const {
    if (o.token.empty()) return true;
    const auto q = query_of(std::string(req.target()));
    if (const auto t = q.find("token"); t != q.end() && t->second == o.token) return true;
    const auto auth = req.find(http::field::authorization);
    return auth != req.end() && std::string(auth->value()) == "Bearer " + o.token;
  }

  Response route(const http::request<http::string_body>& req) {
    if (req.method() != http::verb::get && req.method() != http::verb::head)
      return {405, "application/json", json_error("the view is read-only: GET only")};
    if (!authorised(req)) return {401, "application/json", json_error("a token is needed (?token=...)")};
    std::string path(req.target());
    path = path.substr(0, path.find('?'));
    if (path == "/api/snapshot") {
      try {
        return {200, "application/json", h.snapshot().dump()};
      } catch (const std::exception& e) {
        return {500, "application/json", json_error(e.what())};
      }
    }
    if (path.rfind("/api/", 0) == 0) {
      try {
        return h.api(path.substr(5), query_of(std::string(req.target())));
      } catch (const std::exception& e) {
        return {500, "application/json", json_error(e.what())};
      }
    }
    // Files of the web folder only, by name: no sub-folders, nothing outside it.
    const std::string name = path == "/" ? "index.html" : path == "/episode" ? "episode.html" : path.substr(1);
    if (name.empty() || name.find('/') != std::string::npos || name.find("..") != std::string::npos)
      return {404, "application/json", json_error("no such page: " + path)};
    std::ifstream in(o.web_dir / name, std::ios::binary);
    if (!in) return {404, "application/json", json_error("no such page: " + path)};
    std::stringstream body;
    body << in.rdbuf();
    return {200, content_type(name), body.str()};
  }

  void serve(tcp::socket socket) {
    auto buffer = std::make_shared<beast::flat_buffer>();
    auto req = std::make_shared<http::request<http::string_body>>();
    auto stream = std::make_shared<beast::tcp_stream>(std::move(socket));
    stream->expires_after(std::chrono::seconds(30));
    http::async_read(*stream, *buffer, *req, [self = this, stream, buffer, req](beast::error_code ec, std::size_t) {
      if (ec) return;
      std::string path(req->target());
      path = path.substr(0, path.find('?'));
      if (websocket::is_upgrade(*req) && path == "/ws" && self->authorised(*req)) {
        stream->expires_never();
        auto ws = std::make_shared<Socket>(stream->release_socket(), self->skipped);
        self->sockets.push_back(ws);
        ++self->clients;
        ws->accept(req, [self] { --self->clients; });
        return;
      }
      // An API call may take seconds (a film re-runs its episode): it runs on a thread of its own, so the
      // pushes go on meanwhile; its answer is written back on the server's thread.
      if (path.rfind("/api/", 0) == 0 && path != "/api/snapshot" && self->authorised(*req)) {
        {
          std::lock_guard l(self->work_mutex);
          if (self->working >= kMaxWorking)
            return self->respond(stream, req, {503, "application/json",
                                               json_error("busy with " + std::to_string(kMaxWorking) +
                                                          " calls; try again in a moment")});
          ++self->working;
        }
        std::thread([self, stream = std::move(stream), req = std::move(req)]() mutable {
          Response r = self->route(*req);
          // The answer takes the stream and the request along: this thread holds nothing of the
          // server's once it says it is done.
          asio::post(self->ioc, [self, stream = std::move(stream), req = std::move(req), r = std::move(r)] {
            self->respond(stream, req, r);
          });
          std::lock_guard l(self->work_mutex);
          --self->working;
          self->work_done.notify_all();
        }).detach();
        return;
      }
      self->respond(stream, req, self->route(*req));
    });
  }

  void respond(const std::shared_ptr<beast::tcp_stream>& stream,
               const std::shared_ptr<http::request<http::string_body>>& req, const Response& r) {
    auto res = std::make_shared<http::response<http::string_body>>(static_cast<http::status>(r.status), req->version());
    res->set(http::field::content_type, r.content_type);
    res->set(http::field::cache_control, "no-store");
    if (r.status == 401) res->set(http::field::www_authenticate, "Bearer");
    res->body() = req->method() == http::verb::head ? std::string() : r.body;
    res->keep_alive(req->keep_alive());
    res->prepare_payload();
    stream->expires_after(std::chrono::seconds(30));  // counted from the answer, however long it took
    http::async_write(*stream, *res, [self = this, stream, res](beast::error_code ec, std::size_t) {
      if (ec || !res->keep_alive()) {
        beast::error_code ignored;
        stream->socket().shutdown(tcp::socket::shutdown_send, ignored);
        return;
      }
      self->serve(stream->release_socket());
    });
  }

  void accept() {
    acceptor.async_accept([self = this](beast::error_code ec, tcp::socket socket) {
      if (ec == asio::error::operation_aborted) return;
      if (!ec) self->serve(std::move(socket));
      self->accept();
    });
  }

  void tick() {
    timer.expires_after(o.push_period);
    timer.async_wait([self = this](beast::error_code ec) {
      if (ec) return;
      std::erase_if(self->sockets, [](const auto& w) { return w.expired(); });
      if (!self->sockets.empty()) {
        std::string text;
        try {
          text = self->h.snapshot().dump();
        } catch (const std::exception& e) {
          text = json_error(e.what());
        }
        const auto shared = std::make_shared<const std::string>(std::move(text));
        for (const auto& w : self->sockets)
          if (const auto s = w.lock()) s->push(shared);
      }
      self->tick();
    });
  }
};

Server::Server(ServerOptions options, Handlers handlers) : impl_(std::make_unique<Impl>()) {
  impl_->o = std::move(options);
  impl_->h = std::move(handlers);
  if (!std::filesystem::exists(impl_->o.web_dir / "index.html"))
    throw std::invalid_argument(impl_->o.web_dir.string() + ": no index.html (the view's web folder)");
  beast::error_code ec;
  const auto address = asio::ip::make_address(impl_->o.bind, ec);
  if (ec) throw std::runtime_error("--bind " + impl_->o.bind + ": not an IP address");
  const tcp::endpoint at{address, impl_->o.port};
  auto& a = impl_->acceptor;
  a.open(at.protocol(), ec);
  if (!ec) a.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) a.bind(at, ec);
  if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error("cannot serve on " + impl_->o.bind + ":" + std::to_string(impl_->o.port) + ": " +
                             ec.message() + " (another dh view? --port chooses another)");
  impl_->port = a.local_endpoint().port();
  impl_->accept();
  impl_->tick();
  impl_->thread = std::thread([impl = impl_.get()] { impl->ioc.run(); });
}

Server::~Server() {
  impl_->ioc.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  // API calls still running reach the Impl when they end; their answers are never written.
  std::unique_lock l(impl_->work_mutex);
  impl_->work_done.wait(l, [&] { return impl_->working == 0; });
}

std::uint16_t Server::port() const { return impl_->port; }
std::size_t Server::clients() const { return impl_->clients; }
std::uint64_t Server::skipped_pushes() const { return impl_->skipped; }

}  // namespace dh::view
