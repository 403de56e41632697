// The view's web server over loopback: its pages and API, read-only, a token when one is set, nothing
// outside the web folder, and the WebSocket pushes, which a client that reads nothing does not hold up.
#include <gtest/gtest.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <atomic>
#include <thread>
#include <fstream>

#include <unistd.h>

#include "dh/view/server.hpp"

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
namespace fs = std::filesystem;
using namespace dh::view;

namespace {

struct Web : ::testing::Test {
  void SetUp() override {
    dir = fs::temp_directory_path() / ("dh_view_server_" + std::to_string(getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
    std::ofstream(dir / "index.html") << "<html>channels</html>";
    std::ofstream(dir / "episode.html") << "<html>episode</html>";
    std::ofstream(dir / "view.js") << "'use strict';";
    std::ofstream(dir.parent_path() / "secret.txt") << "not served";
  }
  void TearDown() override { fs::remove_all(dir); }

  Handlers handlers() {
    Handlers h;
    h.snapshot = [this] { return nlohmann::json{{"n", ++snapshots}, {"pad", pad}}; };
    h.api = [](const std::string& name, const std::map<std::string, std::string>& q) {
      if (name == "echo") return Response{200, "application/json", nlohmann::json(q).dump()};
      if (name == "slow") {
        std::this_thread::sleep_for(std::chrono::milliseconds(1500));
        return Response{200, "application/json", "{}"};
      }
      throw std::runtime_error("no such API: " + name);
    };
    return h;
  }
  std::unique_ptr<Server> start(std::string token = "", std::chrono::milliseconds period = std::chrono::milliseconds(50)) {
    ServerOptions o;
    o.port = 0;
    o.token = std::move(token);
    o.web_dir = dir;
    o.push_period = period;
    return std::make_unique<Server>(o, handlers());
  }

  fs::path dir;
  std::atomic<int> snapshots{0};
  std::string pad;
};

http::response<http::string_body> get(std::uint16_t port, const std::string& target, const std::string& auth = "",
                                      http::verb verb = http::verb::get) {
  asio::io_context ioc;
  beast::tcp_stream s(ioc);
  s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{verb, target, 11};
  req.set(http::field::host, "127.0.0.1");
  if (!auth.empty()) req.set(http::field::authorization, auth);
  http::write(s, req);
  beast::flat_buffer b;
  http::response<http::string_body> res;
  http::read(s, b, res);
  return res;
}

}  // namespace

TEST_F(Web, ServesItsPagesAndApiReadOnlyAndNothingElse) {
  auto server = start();
  const auto port = server->port();
  EXPECT_EQ(get(port, "/").body(), "<html>channels</html>");
  EXPECT_EQ(get(port, "/episode?evidence=x.jsonl").body(), "<html>episode</html>");
  auto js = get(port, "/view.js");
  EXPECT_EQ(js[http::field::content_type], "text/javascript; charset=utf-8");
  EXPECT_EQ(nlohmann::json::parse(get(port, "/api/snapshot").body())["n"], 1);
  EXPECT_EQ(nlohmann::json::parse(get(port, "/api/echo?evidence=a%20b.jsonl&x=1").body()),
            nlohmann::json::parse(R"({"evidence":"a b.jsonl","x":"1"})"));
  const auto failing = get(port, "/api/nothing");
  EXPECT_EQ(failing.result_int(), 500);
  EXPECT_NE(failing.body().find("no such API: nothing"), std::string::npos);
  EXPECT_EQ(get(port, "/../secret.txt").result_int(), 404);
  EXPECT_EQ(get(port, "/%2e%2e/secret.txt").result_int(), 404);
  EXPECT_EQ(get(port, "/missing.html").result_int(), 404);
  EXPECT_EQ(get(port, "/api/snapshot", "", http::verb::post).result_int(), 405);
}

TEST_F(Web, ASlowApiCallDoesNotHoldUpThePushes) {
  auto server = start("", std::chrono::milliseconds(50));
  const auto port = server->port();
  asio::io_context ioc;
  websocket::stream<tcp::socket> ws(ioc);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  ws.handshake("127.0.0.1", "/ws");
  std::atomic<bool> answered{false};
  std::thread slow([&] {
    EXPECT_EQ(get(port, "/api/slow").result_int(), 200);
    answered = true;
  });
  int during = 0;
  while (!answered) {
    beast::flat_buffer b;
    ws.read(b);
    during += !answered;
  }
  slow.join();
  EXPECT_GT(during, 10) << "pushes every 50 ms went on through the 1.5 s call";
}

TEST_F(Web, AtMostFourApiCallsRunAtOnceAndTheFifthIsTold) {
  auto server = start();
  const auto port = server->port();
  std::vector<std::thread> calls;
  std::atomic<int> ok{0}, busy{0};
  for (int i = 0; i < 5; ++i) {
    calls.emplace_back([&] {
      const auto r = get(port, "/api/slow");
      (r.result_int() == 200 ? ok : busy) += 1;
      if (r.result_int() == 503) EXPECT_NE(r.body().find("try again"), std::string::npos) << r.body();
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // in order, all within the first call
  }
  for (auto& c : calls) c.join();
  EXPECT_EQ(ok, 4);
  EXPECT_EQ(busy, 1);
}

TEST_F(Web, AWrongOrMissingTokenIs401) {
  auto server = start("s3cret");
  const auto port = server->port();
  EXPECT_EQ(get(port, "/").result_int(), 401);
  EXPECT_EQ(get(port, "/?token=wrong").result_int(), 401);
  EXPECT_EQ(get(port, "/api/snapshot", "Bearer wrong").result_int(), 401);
  EXPECT_EQ(get(port, "/?token=s3cret").result_int(), 200);
  EXPECT_EQ(get(port, "/api/snapshot", "Bearer s3cret").result_int(), 200);
  // The WebSocket too.
  asio::io_context ioc;
  websocket::stream<tcp::socket> ws(ioc);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  EXPECT_THROW(ws.handshake("127.0.0.1", "/ws?token=wrong"), beast::system_error);
}

TEST_F(Web, PushesReachAReaderWhileAClientThatReadsNothingIsSkipped) {
  pad.assign(256 * 1024, 'x');  // big pushes fill a silent client's socket buffers within a second
  auto server = start("", std::chrono::milliseconds(20));
  const auto port = server->port();
  asio::io_context ioc;
  websocket::stream<tcp::socket> silent(ioc), reader(ioc);
  for (auto* ws : {&silent, &reader}) {
    ws->next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    ws->handshake("127.0.0.1", "/ws");
  }
  int last = 0, received = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < until) {
    beast::flat_buffer b;
    reader.read(b);
    const int n = nlohmann::json::parse(beast::buffers_to_string(b.data()))["n"];
    EXPECT_GT(n, last) << "pushes come in order, each newer than the last";
    last = n;
    ++received;
  }
  EXPECT_GT(received, 50) << "about one push every 20 ms for 3 s";
  EXPECT_EQ(server->clients(), 2u);
  EXPECT_GT(server->skipped_pushes(), 0u) << "the silent client's pushes were skipped, not queued";
}
