// Debian's chromium, headless, driven over its DevTools protocol (a WebSocket on loopback), for tests of
// the view's page. Every request it makes is recorded; the network rule holds by construction: every
// host name resolves to nothing and every address but loopback goes to a closed local proxy port, and
// the background services that would phone home are off.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/core/detail/base64.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace dh::itest {

class HeadlessChromium {
 public:
  /// Starts chromium on about:blank with its profile in `dir`; throws std::runtime_error when it does not
  /// come up within 30 s.
  explicit HeadlessChromium(const std::filesystem::path& dir) : dir_(dir) {
    std::filesystem::create_directories(dir_ / "profile");
    const std::vector<std::string> args{
        "chromium", "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
        "--disable-sync",
        "--disable-background-networking", "--disable-component-update", "--disable-default-apps",
        "--disable-domain-reliability", "--disable-features=MediaRouter,OptimizationHints",
        "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1", "--proxy-server=http://127.0.0.1:9",
        "--window-size=1280,900", "--remote-debugging-port=0", "--user-data-dir=" + (dir_ / "profile").string(),
        "about:blank"};
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    const std::string log = (dir_ / "chromium.log").string();
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    const int rc = posix_spawnp(&pid_, "chromium", &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw std::runtime_error("cannot start chromium (apt-get install chromium; scripts/setup does)");
    std::uint16_t port = 0;
    for (auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
         !port && std::chrono::steady_clock::now() < until; std::this_thread::sleep_for(std::chrono::milliseconds(100)))
      std::ifstream(dir_ / "profile" / "DevToolsActivePort") >> port;
    if (!port) throw std::runtime_error("chromium did not open its DevTools port; see " + log);
    // The page target's own socket.
    namespace http = boost::beast::http;
    boost::beast::tcp_stream s(ioc_);
    s.connect({boost::asio::ip::make_address("127.0.0.1"), port});
    http::request<http::string_body> req{http::verb::get, "/json/list", 11};
    req.set(http::field::host, "127.0.0.1");
    http::write(s, req);
    boost::beast::flat_buffer b;
    http::response<http::string_body> res;
    http::read(s, b, res);
    std::string target;
    for (const auto& t : nlohmann::json::parse(res.body()))
      if (t["type"] == "page") target = t["webSocketDebuggerUrl"];
    if (target.empty()) throw std::runtime_error("chromium has no page target: " + res.body());
    const auto path = target.substr(target.find('/', std::string("ws://").size()));
    ws_.next_layer().connect({boost::asio::ip::make_address("127.0.0.1"), port});
    ws_.handshake("127.0.0.1:" + std::to_string(port), path);
    call("Network.enable");
    call("Page.enable");
  }
  ~HeadlessChromium() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }

  /// A DevTools command's result; events that come meanwhile are kept (requests() lists the URLs).
  nlohmann::json call(const std::string& method, nlohmann::json params = nlohmann::json::object()) {
    const int id = ++id_;
    const std::string text = nlohmann::json{{"id", id}, {"method", method}, {"params", std::move(params)}}.dump();
    ws_.write(boost::asio::buffer(text));
    for (;;) {
      boost::beast::flat_buffer b;
      ws_.read(b);
      const auto m = nlohmann::json::parse(boost::beast::buffers_to_string(b.data()));
      if (m.contains("method") && m["method"] == "Network.requestWillBeSent")
        requests_.push_back(m["params"]["request"]["url"]);
      if (m.value("id", 0) != id) continue;
      if (m.contains("error")) throw std::runtime_error(method + ": " + m["error"].dump());
      return m["result"];
    }
  }
  /// Evaluates `js` in the page; its value (JSON-serialisable).
  nlohmann::json eval(const std::string& js) {
    const auto r = call("Runtime.evaluate", {{"expression", js}, {"returnByValue", true}, {"awaitPromise", true}});
    return r["result"].value("value", nlohmann::json());
  }
  void go(const std::string& url) { call("Page.navigate", {{"url", url}}); }
  /// Waits until `js` is true in the page, at most `timeout`.
  bool wait_for(const std::string& js, std::chrono::milliseconds timeout) {
    for (auto until = std::chrono::steady_clock::now() + timeout; std::chrono::steady_clock::now() < until;
         std::this_thread::sleep_for(std::chrono::milliseconds(100)))
      if (eval("Boolean(" + js + ")") == true) return true;
    return false;
  }
  /// A PNG of the element `selector` (or the whole viewport), written to `file`.
  void screenshot(const std::filesystem::path& file, const std::string& selector = "") {
    nlohmann::json params{{"format", "png"}};
    if (!selector.empty()) {
      const auto r = eval("(() => { const b = document.querySelector('" + selector +
                          "').getBoundingClientRect(); return {x: b.x, y: b.y + window.scrollY, width: b.width, height: b.height}; })()");
      params["clip"] = {{"x", r["x"]}, {"y", r["y"]}, {"width", r["width"]}, {"height", r["height"]}, {"scale", 1}};
      params["captureBeyondViewport"] = true;
    }
    const std::string b64 = call("Page.captureScreenshot", params)["data"];
    std::ofstream(file, std::ios::binary) << decode_base64(b64);
  }
  const std::vector<std::string>& requests() const { return requests_; }

 private:
  static std::string decode_base64(const std::string& in) {
    std::string out(boost::beast::detail::base64::decoded_size(in.size()), '\0');
    const auto n = boost::beast::detail::base64::decode(out.data(), in.data(), in.size());
    out.resize(n.first);
    return out;
  }

  std::filesystem::path dir_;
  pid_t pid_ = -1;
  boost::asio::io_context ioc_;
  boost::beast::websocket::stream<boost::asio::ip::tcp::socket> ws_{ioc_};
  int id_ = 0;
  std::vector<std::string> requests_;
};

}  // namespace dh::itest
