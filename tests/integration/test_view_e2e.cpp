// dh view over a real deployment: during a campaign the channels pane's steps move over the WebSocket and
// the campaign pane counts to the end, both read from DDS only (the governor's rt/dh/evidence, dh
// campaign's rt/dh/campaign/progress); an episode page's timeline and filmstrip come from its evidence,
// and a file outside the runs folder is refused with its reason. Headless chromium loads the page the
// while: its panes fill and change over the WebSocket, the episode page shows its timeline and filmstrip,
// a missing file gets a page that names it, no request leaves 127.0.0.1, and each pane's screenshot is
// kept in build/test_output/view/.
#include <signal.h>
#include <sys/wait.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "campaign_helpers.hpp"
#include "harness.hpp"
#include "headless_chromium.hpp"

using namespace dh;
using namespace std::chrono_literals;
namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using nlohmann::json;

namespace {

http::response<http::string_body> get(std::uint16_t port, const std::string& target) {
  asio::io_context ioc;
  beast::tcp_stream s(ioc);
  s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{http::verb::get, target, 11};
  req.set(http::field::host, "127.0.0.1");
  http::write(s, req);
  beast::flat_buffer b;
  http::response<http::string_body> res;
  http::read(s, b, res);
  return res;
}

std::string encode(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '/' || c == '.' || c == '_' || c == '-') out += static_cast<char>(c);
    else {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", c);
      out += buf;
    }
  }
  return out;
}

}  // namespace

TEST(ViewE2E, ACampaignIsSeenLiveAndItsEpisodesPagesComeFromTheirEvidence) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");
  const auto port_file = env.runs / "view.port";
  const pid_t view = itest::spawn_shell("exec " + dh + " view --port 0 --port-file " + port_file.string() + " > " +
                                        (env.runs / "view.log").string() + " 2>&1");
  ASSERT_GT(view, 0);
  std::uint16_t port = 0;
  for (auto until = std::chrono::steady_clock::now() + 20s; !port && std::chrono::steady_clock::now() < until;
       std::this_thread::sleep_for(50ms))
    std::ifstream(port_file) >> port;
  ASSERT_GT(port, 0) << "dh view never said its port; see " << (env.runs / "view.log");
  EXPECT_NE(get(port, "/").body().find("Channels"), std::string::npos);

  const std::string base = "http://127.0.0.1:" + std::to_string(port);
  itest::HeadlessChromium browser(env.runs / "chromium");
  browser.go(base + "/");
  ASSERT_TRUE(browser.wait_for("document.getElementById('link').textContent === 'live'", 20s))
      << "the page's WebSocket did not open";

  asio::io_context ioc;
  websocket::stream<tcp::socket> ws(ioc);
  ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  ws.handshake("127.0.0.1", "/ws");

  const auto db = env.runs / "c.db";
  const pid_t campaign = itest::spawn_shell("exec " + dh + " campaign --arms full --cells goal --tasks 0-9 --seeds 1 " +
                                            "--ready-timeout-ms 20000 --db " + db.string() + " > " +
                                            (env.runs / "campaign.log").string() + " 2>&1");
  ASSERT_GT(campaign, 0);
  std::map<std::string, std::set<unsigned>> steps_seen;  // episode -> steps shown while it ran
  std::set<std::string> hosts;
  json last_campaign;
  std::string evidence;
  std::set<std::string> page_steps;  // the page's step column, as the browser shows it while episodes run
  auto next_look = std::chrono::steady_clock::now();
  for (auto until = std::chrono::steady_clock::now() + 150s; std::chrono::steady_clock::now() < until;) {
    if (std::chrono::steady_clock::now() >= next_look) {
      page_steps.insert(browser.eval("[...document.querySelectorAll('#channels td.step')].map(td => td.textContent).join(',')")
                            .get<std::string>());
      next_look += 1s;
    }
    beast::flat_buffer b;
    ws.read(b);
    const json s = json::parse(beast::buffers_to_string(b.data()));
    for (const auto& c : s["channels"]) {
      if (c["state"] == "running" && c.contains("step")) steps_seen[c["episode_id"]].insert(c["step"].get<unsigned>());
      if (!c["host"].get<std::string>().empty()) hosts.insert(c["host"]);
      if (c["state"] == "ended" && c.value("outcome", "") == "success" && evidence.empty()) evidence = c["evidence"];
    }
    for (const auto& c : s["campaigns"])
      if (c["campaign"] == db.string()) last_campaign = c;
    if (!last_campaign.is_null() && last_campaign["finished"].get<bool>()) break;
  }
  int status = 0;
  waitpid(campaign, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "see " << (env.runs / "campaign.log");

  std::size_t moving = 0;
  for (const auto& [episode, steps] : steps_seen) moving += steps.size() >= 3;
  EXPECT_GE(moving, 3u) << "episodes whose step was seen to move at least twice over the WebSocket";
  EXPECT_EQ(hosts, (std::set<std::string>{"local_a", "local_b"}));
  ASSERT_FALSE(last_campaign.is_null()) << "no progress of the campaign on rt/dh/campaign/progress";
  EXPECT_EQ(last_campaign["done"], 10);
  EXPECT_EQ(last_campaign["total"], 10);
  ASSERT_EQ(last_campaign["cells"].size(), 1u);
  EXPECT_EQ(last_campaign["cells"][0]["episodes"], 10);
  EXPECT_EQ(last_campaign["cells"][0]["successes"], last_campaign["successes"]);

  // The page followed it: its step column changed, and its campaign pane counted to the end.
  EXPECT_GE(page_steps.size(), 3u) << "the channels pane in the browser changed at least twice";
  ASSERT_TRUE(browser.wait_for("document.getElementById('campaigns').textContent.includes('10 / 10')", 5s));
  const auto shots = paths::bin_dir().parent_path() / "test_output" / "view";
  std::filesystem::create_directories(shots);
  browser.screenshot(shots / "channels.png", "#channels");
  browser.screenshot(shots / "campaigns.png", "#campaigns");

  // An episode's page: its timeline from the evidence file the channel named, and its filmstrip.
  ASSERT_FALSE(evidence.empty()) << "no channel showed a finished successful episode";
  const auto page = get(port, "/api/episode?evidence=" + encode(evidence));
  ASSERT_EQ(page.result_int(), 200) << page.body();
  const json t = json::parse(page.body());
  EXPECT_EQ(t["outcome"], "success");
  std::set<std::string> kinds;
  for (const auto& e : t["events"]) kinds.insert(e["kind"]);
  for (const char* k : {"advice", "grounding", "dispatch", "end"}) EXPECT_TRUE(kinds.count(k)) << k;
  const auto film = get(port, "/api/film?evidence=" + encode(evidence));
  ASSERT_EQ(film.result_int(), 200) << film.body();
  EXPECT_EQ(film[http::field::content_type], "image/png");
  EXPECT_EQ(film.body().substr(1, 3), "PNG");

  // The same in the browser, from the link in the channels pane.
  browser.go(base + "/episode?evidence=" + encode(evidence));
  EXPECT_TRUE(browser.wait_for("document.querySelectorAll('#timeline tbody tr').length > 3", 20s));
  EXPECT_TRUE(browser.wait_for("document.getElementById('film').naturalWidth > 0", 60s)) << "the filmstrip loaded";
  EXPECT_NE(browser.eval("document.getElementById('summary').textContent").get<std::string>().find("success"),
            std::string::npos);
  browser.screenshot(shots / "episode.png");
  browser.go(base + "/episode?evidence=" + encode((env.runs / "evidence" / "none.jsonl").string()));
  EXPECT_TRUE(browser.wait_for("document.getElementById('summary').textContent.includes('no such evidence file')", 20s))
      << browser.eval("document.getElementById('summary').textContent");
  browser.screenshot(shots / "missing.png");
  for (const auto& url : browser.requests())
    EXPECT_TRUE(url.rfind(base, 0) == 0 || url.rfind("ws://127.0.0.1:" + std::to_string(port), 0) == 0 ||
                url.rfind("data:", 0) == 0 || url == "about:blank")
        << "the page asked for " << url;
  EXPECT_GE(browser.requests().size(), 5u) << "the pages, their script, style and API calls were seen";

  // Bad input is named, not served.
  const auto outside = get(port, "/api/episode?evidence=/etc/passwd.jsonl");
  EXPECT_EQ(outside.result_int(), 403);
  EXPECT_NE(outside.body().find("outside the folders this view serves"), std::string::npos) << outside.body();
  const auto missing = get(port, "/api/episode?evidence=" + encode((env.runs / "evidence" / "none.jsonl").string()));
  EXPECT_EQ(missing.result_int(), 422);
  EXPECT_NE(missing.body().find("none.jsonl: no such evidence file"), std::string::npos) << missing.body();

  kill(view, SIGINT);
  waitpid(view, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "dh view stops cleanly on Ctrl-C";
}
