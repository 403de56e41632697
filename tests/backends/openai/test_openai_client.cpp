// The openai backend over real HTTP on loopback: the libcurl transport and OpenAiPlanner against the
// scripted server (fake_openai_server.py), one mode per test, plus an endpoint nothing listens on. The
// recorded request bodies show what a real server would get.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <thread>

#include "dh/planner/curl_transport.hpp"
#include "dh/planner/openai.hpp"
#include "fake_server.hpp"

using namespace dh;
using namespace dh::planner;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

PlanContext context(const std::string& instruction = "put the bowl on the plate") {
  EntityState bowl, plate;
  bowl.name = bowl.kind = "bowl";
  plate.name = plate.kind = "plate";
  return {instruction, {bowl, plate}, {"pick_place", "push"}, {}};
}

OpenAiConfig config(const std::string& endpoint, double timeout_s = 2) {
  OpenAiConfig c;
  c.endpoint = endpoint;
  c.model = "fake-model";
  c.timeout = std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000));
  return c;
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

PlannerAdvice plan(const std::string& endpoint, const std::vector<EncodedImage>& images = {},
                   const std::function<bool()>& cancelled = {}, double timeout_s = 2) {
  CurlTransport http;
  return OpenAiPlanner(config(endpoint, timeout_s), http)
      .plan(context(), {{"pick_place", {"object", "target"}}}, images, cancelled);
}

}  // namespace

TEST(OpenAiClient, ValidAdvisoryAndWhatTheServerGot) {
  otest::FakeOpenAiServer server("valid");
  const PlannerAdvice a = plan(server.endpoint());
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  EXPECT_EQ(a.args, (Args{{"object", "bowl"}, {"target", "plate"}}));
  const auto got = server.requests();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0]["path"], "/v1/chat/completions");
  EXPECT_TRUE(got[0]["authorization"].is_null());
  const auto& body = got[0]["body"];
  EXPECT_EQ(body["model"], "fake-model");
  EXPECT_DOUBLE_EQ(body["temperature"].get<double>(), 0.1);
  EXPECT_EQ(body["max_tokens"], 2048);
  EXPECT_EQ(body["response_format"]["type"], "json_schema");
  EXPECT_EQ(body["response_format"]["json_schema"]["name"], "advisory");
  EXPECT_EQ(body["response_format"]["json_schema"]["schema"]["properties"]["capability"]["enum"],
            nlohmann::json({"pick_place", "push", ""}));
  EXPECT_EQ(body["messages"][0]["role"], "system");
  EXPECT_TRUE(has(body["messages"][1]["content"], "Instruction: put the bowl on the plate"));
  EXPECT_TRUE(has(body["messages"][1]["content"], "- pick_place(object, target)"));
}

TEST(OpenAiClient, BearerTokenFromTheEnvironment) {
  otest::FakeOpenAiServer server("valid");
  setenv("DH_TEST_FAKE_KEY", "sk-local-only", 1);
  OpenAiConfig c = config(server.endpoint());
  c.api_key_env = "DH_TEST_FAKE_KEY";
  CurlTransport http;
  const PlannerAdvice a = OpenAiPlanner(c, http).plan(context(), {}, {});
  unsetenv("DH_TEST_FAKE_KEY");
  ASSERT_FALSE(a.refused) << a.reason;
  const auto got = server.requests();
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0]["authorization"], "Bearer sk-local-only");
}

TEST(OpenAiClient, ImagesArriveAsDataUrlParts) {
  otest::FakeOpenAiServer server("valid");
  const std::string jpeg("\xFF\xD8\xFF\xE0jpegdata", 12), png("\x89PNG\r\n\x1a\npngdata", 15);
  const PlannerAdvice a = plan(server.endpoint(), {{"agentview", "image/jpeg", jpeg}, {"wrist", "", png}});
  ASSERT_FALSE(a.refused) << a.reason;
  const auto got = server.requests();
  ASSERT_EQ(got.size(), 1u);
  const auto& content = got[0]["body"]["messages"][1]["content"];
  ASSERT_TRUE(content.is_array());
  std::vector<std::string> urls;
  for (const auto& part : content)
    if (part["type"] == "image_url") urls.push_back(part["image_url"]["url"]);
  ASSERT_EQ(urls.size(), 2u);
  EXPECT_EQ(urls[0], "data:image/jpeg;base64," + openai::base64(jpeg));
  EXPECT_EQ(urls[1], "data:image/png;base64," + openai::base64(png));
  EXPECT_EQ(content[0]["type"], "text");
  EXPECT_TRUE(has(content[0]["text"], "put the bowl on the plate"));
}

TEST(OpenAiClient, NonJsonThenRepairedGivesTheAdvice) {
  otest::FakeOpenAiServer server("repair");
  const PlannerAdvice a = plan(server.endpoint());
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  const auto got = server.requests();
  ASSERT_EQ(got.size(), 2u);
  const auto& repair = got[1]["body"];
  ASSERT_EQ(repair["messages"].size(), 4u);
  EXPECT_EQ(repair["messages"][2]["role"], "assistant");
  EXPECT_TRUE(has(repair["messages"][3]["content"], "not JSON"));
  EXPECT_EQ(repair["response_format"], got[0]["body"]["response_format"]);
}

TEST(OpenAiClient, EveryFailureModeIsARefusalWithItsReason) {
  struct Case {
    std::string mode;
    std::size_t requests;
    std::vector<std::string> expect;
  };
  const std::vector<Case> cases{
      {"garbage", 2, {"no usable advisory after one repair request", "not JSON"}},
      {"schema", 2, {"no usable advisory after one repair request", "schema violation"}},
      {"unknown", 2, {"'teleport' is not among the eligible capabilities (pick_place, push)"}},
      {"http500", 1, {"HTTP 500 (CUDA out of memory (fake))", "see its log"}},
      {"notjson", 1, {"the response body is not JSON", "OpenAI-compatible"}},
      {"refuse", 1, {"the model refused: there is no bowl in this scene"}},
  };
  for (const auto& c : cases) {
    otest::FakeOpenAiServer server(c.mode);
    const PlannerAdvice a = plan(server.endpoint());
    EXPECT_TRUE(a.refused) << c.mode;
    EXPECT_EQ(server.requests().size(), c.requests) << c.mode;
    if (c.mode != "refuse") {
      EXPECT_TRUE(has(a.reason, server.endpoint() + "/v1/chat/completions")) << a.reason;
    }
    for (const auto& e : c.expect) EXPECT_TRUE(has(a.reason, e)) << c.mode << ": " << a.reason;
  }
}

TEST(OpenAiClient, ASlowServerTimesOut) {
  otest::FakeOpenAiServer server("sleep", 30);
  const auto t0 = Clock::now();
  const PlannerAdvice a = plan(server.endpoint(), {}, {}, 1.0);
  EXPECT_LT(Clock::now() - t0, 20s) << "answered before a generous deadline";
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "no reply to the request")) << a.reason;
  EXPECT_TRUE(has(a.reason, "--timeout-s")) << a.reason;
}

TEST(OpenAiClient, NothingListeningIsARefusal) {
  const std::string endpoint = "http://127.0.0.1:" + std::to_string(otest::unused_port());
  const PlannerAdvice a = plan(endpoint);
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, endpoint + "/v1/chat/completions")) << a.reason;
  EXPECT_TRUE(has(a.reason, "cannot connect")) << a.reason;
  EXPECT_TRUE(has(a.reason, "start the model server")) << a.reason;
}

TEST(OpenAiClient, ATransferInFlightCanBeCancelled) {
  otest::FakeOpenAiServer server("sleep", 30);
  std::atomic<bool> cancel{false};
  std::thread t([&] {
    std::this_thread::sleep_for(300ms);
    cancel = true;
  });
  const auto t0 = Clock::now();
  const PlannerAdvice a = plan(
      server.endpoint(), {}, [&] { return cancel.load(); }, 60);
  t.join();
  EXPECT_LT(Clock::now() - t0, 20s) << "cancelled long before the 60 s timeout";
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "cancelled")) << a.reason;
}
