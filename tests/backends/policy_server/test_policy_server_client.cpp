// PolicyServerClient against a real WebSocket server: fake_policy_server.py (openpi's protocol and numpy
// encoding, written out by hand), started by each test on 127.0.0.1 with a mode, and a port nothing
// listens on. Deadlines are generous; nothing here measures speed.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "dh/policy/policy_server_client.hpp"
#include "../../support/unused_port.hpp"
#include "fake_server.hpp"

extern char** environ;

using namespace dh::policy;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

constexpr auto kTimeout = 2000ms;  // the client's timeout in these tests

using dh::test::FakeServer;

FakeServer start(const std::string& mode, std::vector<std::string> extra = {}) {
  extra.insert(extra.begin(), {"--mode", mode});
  return FakeServer(extra);
}

using dh::testsupport::unused_port;

CameraImage pattern(const std::string& name, int w, int h, int seed) {
  CameraImage im{name, w, h, std::vector<std::uint8_t>(std::size_t(w) * h * 3)};
  for (std::size_t i = 0; i < im.rgb.size(); ++i)
    im.rgb[i] = static_cast<std::uint8_t>((i * (3 + seed) + seed) % 256);
  return im;
}

PolicyQuery libero_query() {
  PolicyQuery q;
  q.agent_view = pattern("agentview", 224, 224, 1);
  q.wrist = pattern("robot0_eye_in_hand", 224, 224, 2);
  q.state = {0.12f, -0.03f, 1.18f, 3.1f, 0.02f, -0.4f, 0.0395f, -0.0391f};
  q.prompt = "put the bowl on the plate";
  return q;
}

unsigned code_of(const std::vector<std::uint8_t>& bytes) {
  std::uint64_t sum = 0;
  for (const auto b : bytes) sum += b;
  return unsigned(sum % 1000);
}

// The chunk fake_policy_server.py answers for `q` (see its docstring), the images as sent.
void expect_fake_chunk(const ActionChunk& chunk, const PolicyQuery& q, const CameraImage& sent_agent,
                       const CameraImage& sent_wrist) {
  ASSERT_EQ(chunk.actions.size(), 10u);
  unsigned prompt = 0;
  for (const unsigned char c : q.prompt) prompt += c;
  const double col6[] = {double(prompt % 1000), double(code_of(sent_agent.rgb)),
                         double(code_of(sent_wrist.rgb)), double(q.state[6] + q.state[7])};
  for (int i = 0; i < 10; ++i) {
    for (int j = 0; j < 6; ++j)
      EXPECT_NEAR(chunk.actions[i][j], double(q.state[j] + float(0.25 * i)), 1e-6) << i << "," << j;
    EXPECT_NEAR(chunk.actions[i][6], i < 4 ? col6[i] : double(i), 1e-6) << "row " << i;
  }
  EXPECT_DOUBLE_EQ(chunk.infer_ms, 12.5);
}

// Runs `call`, expects a PolicyServerError of `kind`, returns its message.
template <class F>
std::string expect_error(F&& call, PolicyServerErrorKind kind, const std::string& url) {
  try {
    call();
  } catch (const PolicyServerError& e) {
    EXPECT_EQ(e.kind(), kind) << to_string(e.kind()) << ": " << e.what();
    EXPECT_EQ(e.url(), url + "/");
    EXPECT_NE(std::string(e.what()).find(url), std::string::npos) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no PolicyServerError";
  return "";
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(PolicyServerClient, RoundTripsAnObservationThroughARealServer) {
  const auto server = start("normal");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  EXPECT_FALSE(client.connected());
  const auto q = libero_query();
  const auto chunk = client.infer(q);
  expect_fake_chunk(chunk, q, q.agent_view, q.wrist);
  EXPECT_GT(chunk.round_trip_ms, 0.0);
  EXPECT_TRUE(client.connected());
  EXPECT_EQ(client.metadata()["fake"], true);
  EXPECT_EQ(client.metadata()["connection"], 1);
  EXPECT_EQ(client.metadata()["action_horizon"], 10);

  // Further requests on the same connection, each answered from its own observation.
  auto q2 = q;
  q2.state[0] = -0.5f;
  q2.prompt = "open the middle drawer of the cabinet";
  expect_fake_chunk(client.infer(q2), q2, q2.agent_view, q2.wrist);
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
  EXPECT_EQ(client.connections_made(), 1u);
}

TEST(PolicyServerClient, ResizesOtherImageSizesWithPaddingBeforeSending) {
  // The server accepts nothing but 224 × 224 × 3 uint8; its reply carries checksums of what arrived.
  const auto server = start("normal");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  auto q = libero_query();
  q.agent_view = pattern("agentview", 256, 256, 5);
  q.wrist = pattern("robot0_eye_in_hand", 320, 240, 6);
  const auto chunk = client.infer(q);
  expect_fake_chunk(chunk, q, resize_with_pad(q.agent_view), resize_with_pad(q.wrist));
}

TEST(PolicyServerClient, AcceptsFloat64Actions) {
  const auto server = start("normal", {"--dtype", "f8"});
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto q = libero_query();
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
}

TEST(PolicyServerClient, ServerErrorQuotesTheTracebackAndTheNextCallReconnects) {
  const auto server = start("error");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto q = libero_query();
  const auto e = expect_error([&] { client.infer(q); }, PolicyServerErrorKind::kServerError, server.url());
  EXPECT_TRUE(has(e, "Traceback (most recent call last)")) << e;
  EXPECT_TRUE(has(e, "RuntimeError: fake policy failure: the model is not loaded")) << e;
  EXPECT_TRUE(has(e, "closed with code 1011")) << e;
  EXPECT_TRUE(has(e, "server's log")) << e;
  EXPECT_FALSE(client.connected());
  expect_error([&] { client.infer(q); }, PolicyServerErrorKind::kServerError, server.url());
  EXPECT_EQ(client.connections_made(), 2u);
  EXPECT_EQ(client.metadata()["connection"], 2);
}

TEST(PolicyServerClient, NonMsgpackReplyIsABadReply) {
  const auto server = start("garbage");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kBadReply, server.url());
  EXPECT_TRUE(has(e, "the reply is not msgpack")) << e;
  EXPECT_TRUE(has(e, "c1 20 74 68")) << e;
  EXPECT_TRUE(has(e, "openpi policy server")) << e;
  // The connection is still in step (one reply per request): kept.
  expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kBadReply, server.url());
  EXPECT_EQ(client.connections_made(), 1u);
}

TEST(PolicyServerClient, ReplyWithoutActionsIsABadReply) {
  const auto server = start("no-actions");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kBadReply, server.url());
  EXPECT_TRUE(has(e, "no \"actions\" (its keys: \"server_timing\")")) << e;
}

TEST(PolicyServerClient, WrongShapeOrDtypeIsABadReply) {
  {
    const auto server = start("wrong-shape");
    ASSERT_TRUE(server.running());
    PolicyServerClient client(server.url(), kTimeout);
    const auto e =
        expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kBadReply, server.url());
    EXPECT_TRUE(has(e, "shape (10, 6), expected (H, 7)")) << e;
  }
  const auto server = start("wrong-dtype");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kBadReply, server.url());
  EXPECT_TRUE(has(e, "dtype \"<i8\"")) << e;
}

TEST(PolicyServerClient, SlowReplyTimesOutWithinTheTimeoutThenTheNextCallReconnects) {
  const auto server = start("slow", {"--delay", "8"});
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto t0 = Clock::now();
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kTimeout, server.url());
  EXPECT_LT(Clock::now() - t0, kTimeout + 3s) << "the call outlived its timeout";
  EXPECT_TRUE(has(e, "no reply within the timeout of 2000 ms")) << e;
  EXPECT_TRUE(has(e, "raise the timeout")) << e;
  EXPECT_FALSE(client.connected());
  // Only the server's first request is slow: the next call gets a new connection and its answer.
  const auto q = libero_query();
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
  EXPECT_EQ(client.connections_made(), 2u);
}

TEST(PolicyServerClient, ServerClosingAfterTheMetadataIsReported) {
  const auto server = start("close-after-metadata");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kClosed, server.url());
  EXPECT_TRUE(has(e, "closed the connection (code 1000 \"fake server: closing after the metadata\")")) << e;
  EXPECT_TRUE(has(e, "instead of replying")) << e;
  EXPECT_FALSE(client.connected());
}

TEST(PolicyServerClient, SilentServerTimesOutWaitingForTheMetadata) {
  const auto server = start("silent");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto t0 = Clock::now();
  const auto e = expect_error([&] { client.connect(); }, PolicyServerErrorKind::kTimeout, server.url());
  EXPECT_LT(Clock::now() - t0, kTimeout + 3s);
  EXPECT_TRUE(has(e, "no metadata frame")) << e;
  EXPECT_FALSE(client.connected());
}

TEST(PolicyServerClient, NothingListeningIsUnreachable) {
  const std::string url = "ws://127.0.0.1:" + std::to_string(unused_port());
  PolicyServerClient client(url, kTimeout);
  const auto t0 = Clock::now();
  const auto e =
      expect_error([&] { client.infer(libero_query()); }, PolicyServerErrorKind::kUnreachable, url);
  EXPECT_LT(Clock::now() - t0, kTimeout + 3s);
  EXPECT_TRUE(has(e, "connection refused")) << e;
  EXPECT_TRUE(has(e, "serve_policy.py")) << e;
}

TEST(PolicyServerClient, ReconnectsTransparentlyWhenTheServerDroppedAnIdleConnection) {
  // The server closes every connection after one reply; the next call finds its connection closed and
  // sends again on a new one, within the same call.
  const auto server = start("drop-after-reply");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto q = libero_query();
  for (unsigned n = 1; n <= 3; ++n) {
    expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
    EXPECT_EQ(client.connections_made(), n);
    EXPECT_EQ(client.metadata()["connection"], n);
  }
}

TEST(PolicyServerClient, ReconnectsWhenTheServerClosedAnIdleConnectionOnKeepalive) {
  // websockets pings every client and closes (1011) when no pong comes; this client answers pings only
  // while it waits for a reply, so an idle connection is lost: the next call must not fail because of it.
  const auto server = start("normal", {"--ping-interval", "0.2"});
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  const auto q = libero_query();
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
  std::this_thread::sleep_for(2s);  // ≫ ping interval + ping timeout
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
  EXPECT_EQ(client.connections_made(), 2u);
}

TEST(PolicyServerClient, ExplicitConnectAndClose) {
  const auto server = start("normal");
  ASSERT_TRUE(server.running());
  PolicyServerClient client(server.url(), kTimeout);
  EXPECT_TRUE(client.metadata().empty());
  client.connect();
  EXPECT_TRUE(client.connected());
  EXPECT_EQ(client.metadata()["mode"], "normal");
  client.connect();  // already connected: nothing happens
  EXPECT_EQ(client.connections_made(), 1u);
  client.close();
  EXPECT_FALSE(client.connected());
  const auto q = libero_query();
  expect_fake_chunk(client.infer(q), q, q.agent_view, q.wrist);
  EXPECT_EQ(client.connections_made(), 2u);
}

TEST(PolicyServerClient, UrlsAreParsedOrRefused) {
  EXPECT_EQ(PolicyServerClient("ws://127.0.0.1:8000").url(), "ws://127.0.0.1:8000/");
  EXPECT_EQ(PolicyServerClient("localhost").url(), "ws://localhost:8000/");
  EXPECT_EQ(PolicyServerClient("10.0.0.5:9000").url(), "ws://10.0.0.5:9000/");
  EXPECT_EQ(PolicyServerClient("ws://[::1]:8001/policy").url(), "ws://[::1]:8001/policy");
  for (const char* bad : {"wss://host:8000", "http://host:8000", "ws://:8000", "ws://host:0",
                          "ws://host:99999", "ws://host:80a", "ws://::1:8000", "ws://[::1"}) {
    try {
      PolicyServerClient c(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const PolicyServerError& e) {
      EXPECT_EQ(e.kind(), PolicyServerErrorKind::kInvalidUrl) << bad;
      EXPECT_TRUE(has(e.what(), "ws://host:port")) << e.what();
    }
  }
  EXPECT_THROW(PolicyServerClient("ws://127.0.0.1:8000", 0ms), PolicyServerError);
}

TEST(PolicyServerClient, InconsistentImageIsTheCallersError) {
  PolicyServerClient client("ws://127.0.0.1:" + std::to_string(unused_port()), kTimeout);
  auto q = libero_query();
  q.wrist.rgb.resize(100);
  EXPECT_THROW(client.infer(q), std::invalid_argument);
}
