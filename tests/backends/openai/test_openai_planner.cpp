// The planner process with --backend openai over real DDS (loopback, a domain of the test's own),
// against the scripted OpenAI-compatible server: the Advice for a valid reply, a repaired one, every
// failure mode (a refusal with its reason), requests served concurrently, superseded requests dropped.
#include <chrono>
#include <map>
#include <optional>

#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/plannerPubSubTypes.h"
#include "fake_server.hpp"
#include "harness.hpp"

namespace dh {
using namespace std::chrono_literals;

namespace {

msg::EntityPose pose(const std::string& name, const std::string& kind, double x, double y) {
  msg::EntityPose e;
  e.name(name);
  e.kind(kind);
  e.pose().p({x, y, 0.0});
  e.pose().q({1.0, 0.0, 0.0, 0.0});
  e.half_extents({0.05, 0.05, 0.03});
  return e;
}

/// Talks to the planner the way the governor does: plan requests out, advice in.
class PlannerClient {
 public:
  PlannerClient()
      : participant_("itest_openai"),
        requests_(participant_, topics::kPlanRequest, dds::Qos::Planner),
        advice_(participant_, topics::kAdvice, dds::Qos::Planner,
                {[this](const msg::Advice& a, const auto&) {
                   std::lock_guard l(m_);
                   got_[a.request_id()] = a;
                   order_.push_back(a.request_id());
                   cv_.notify_all();
                 },
                 {},
                 {}}) {}

  /// Both directions discovered (the planner's reader and writer matched ours).
  bool ready() {
    for (int i = 0; i < 200; ++i) {
      if (requests_.matched() >= 1 && advice_.matched() >= 1) {
        std::this_thread::sleep_for(300ms);
        return true;
      }
      std::this_thread::sleep_for(100ms);
    }
    return false;
  }

  void send(std::uint32_t channel, const std::string& id, const std::string& instruction) {
    msg::PlanRequest r;
    r.channel(channel);
    r.request_id(id);
    r.episode_id("ep-" + std::to_string(channel));
    r.instruction(instruction);
    r.scene({pose("bowl", "bowl", -0.17, -0.04), pose("plate", "plate", -0.2, 0.22)});
    for (const auto& e : r.scene()) r.entities().push_back(e.name());
    r.capabilities({"pick_place", "push"});
    r.history({"step 0: episode started"});
    requests_.write(r);
  }

  std::optional<msg::Advice> wait_for(const std::string& id, std::chrono::milliseconds timeout = 30s) {
    if (!itest::wait_until(m_, cv_, timeout, [&] { return got_.count(id) > 0; })) return std::nullopt;
    std::lock_guard l(m_);
    return got_.at(id);
  }
  bool answered(const std::string& id) {
    std::lock_guard l(m_);
    return got_.count(id) > 0;
  }
  std::vector<std::string> order() {
    std::lock_guard l(m_);
    return order_;
  }

 private:
  dds::Participant participant_;
  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::string, msg::Advice> got_;
  std::vector<std::string> order_;
  dds::Writer<msg::PlanRequestPubSubType> requests_;
  dds::Reader<msg::AdvicePubSubType> advice_;
};

cli::ServiceSpec openai_planner(const std::string& endpoint, const std::string& timeout_s = "2") {
  return itest::service("planner", {"--backend", "openai", "--endpoint", endpoint, "--model", "fake-model",
                                    "--timeout-s", timeout_s});
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(OpenAiPlannerNode, ValidAndRepairedAdvisoriesArriveAsAdvice) {
  itest::IsolatedEnv env;
  otest::FakeOpenAiServer server("valid");
  cli::Deployment d({openai_planner(server.endpoint())}, paths::bin_dir(), env.runs / "logs");
  PlannerClient client;
  ASSERT_TRUE(client.ready()) << "the planner never matched";

  client.send(0, "ep-0/p0", "put the bowl on the plate");
  auto a = client.wait_for("ep-0/p0");
  ASSERT_TRUE(a) << "no advice";
  EXPECT_FALSE(a->refused()) << a->reason();
  EXPECT_EQ(a->backend(), "openai");
  EXPECT_EQ(a->channel(), 0u);
  EXPECT_EQ(a->episode_id(), "ep-0");
  EXPECT_EQ(a->capability(), "pick_place");
  ASSERT_EQ(a->args().size(), 2u);
  EXPECT_EQ(a->args()[0].role(), "object");
  EXPECT_EQ(a->args()[0].entity(), "bowl");
  EXPECT_EQ(a->args()[1].role(), "target");
  EXPECT_EQ(a->args()[1].entity(), "plate");

  client.send(1, "ep-1/p0", "put the bowl on the plate fake-mode:repair");
  a = client.wait_for("ep-1/p0");
  ASSERT_TRUE(a) << "no advice";
  EXPECT_FALSE(a->refused()) << a->reason();
  EXPECT_EQ(a->capability(), "pick_place");
  EXPECT_TRUE(has(a->rationale(), "after one repair request")) << a->rationale();

  // What the server got: the snapshot and the sampling settings.
  const auto got = server.requests();
  ASSERT_EQ(got.size(), 3u);
  const auto& body = got[0]["body"];
  EXPECT_DOUBLE_EQ(body["temperature"].get<double>(), 0.1);
  EXPECT_EQ(body["max_tokens"], 2048);
  EXPECT_EQ(body["response_format"]["type"], "json_schema");
  const std::string user = body["messages"][1]["content"];
  EXPECT_TRUE(has(user, "Instruction: put the bowl on the plate")) << user;
  EXPECT_TRUE(has(user, "- bowl: bowl at (-0.170, -0.040, 0.000)")) << user;
  EXPECT_TRUE(has(user, "- step 0: episode started")) << user;
  EXPECT_EQ(got[2]["body"]["messages"].size(), 4u) << "the repair request";
  EXPECT_TRUE(d.exited().empty()) << "the planner crashed";
}

TEST(OpenAiPlannerNode, EveryFailureIsARefusalWithItsReason) {
  itest::IsolatedEnv env;
  otest::FakeOpenAiServer server("valid");
  cli::Deployment d({openai_planner(server.endpoint())}, paths::bin_dir(), env.runs / "logs");
  PlannerClient client;
  ASSERT_TRUE(client.ready()) << "the planner never matched";
  const std::map<std::string, std::vector<std::string>> expect{
      {"garbage", {"no usable advisory after one repair request", "not JSON"}},
      {"schema", {"no usable advisory after one repair request", "schema violation"}},
      {"unknown", {"'teleport' is not among the eligible capabilities (pick_place, push)"}},
      {"http500", {"HTTP 500", "CUDA out of memory", "see its log"}},
      {"notjson", {"not JSON", "OpenAI-compatible"}},
      {"sleep", {"no reply", "--timeout-s", "planner_timeout_ms"}},
  };
  // Why, typed on the wire: attribution reads this, not the words.
  const std::map<std::string, msg::PlannerRefusal> why{
      {"garbage", msg::PLANNER_REFUSAL_MALFORMED}, {"schema", msg::PLANNER_REFUSAL_MALFORMED},
      {"unknown", msg::PLANNER_REFUSAL_PLANNING},  {"http500", msg::PLANNER_REFUSAL_UNAVAILABLE},
      {"notjson", msg::PLANNER_REFUSAL_MALFORMED}, {"sleep", msg::PLANNER_REFUSAL_UNAVAILABLE},
  };
  // One channel per mode, all at once: the planner serves them concurrently.
  std::uint32_t channel = 0;
  for (const auto& [mode, _] : expect)
    client.send(channel++, "req-" + mode, "put the bowl on the plate fake-mode:" + mode);
  for (const auto& [mode, parts] : expect) {
    const auto a = client.wait_for("req-" + mode);
    ASSERT_TRUE(a) << mode << ": no advice";
    EXPECT_TRUE(a->refused()) << mode;
    EXPECT_EQ(a->refusal(), why.at(mode)) << mode;
    EXPECT_EQ(a->backend(), "openai");
    EXPECT_TRUE(a->capability().empty()) << mode;
    EXPECT_TRUE(has(a->reason(), server.endpoint() + "/v1/chat/completions")) << mode << ": " << a->reason();
    for (const auto& p : parts) EXPECT_TRUE(has(a->reason(), p)) << mode << ": " << a->reason();
  }
  EXPECT_TRUE(d.exited().empty()) << "the planner crashed";
}

TEST(OpenAiPlannerNode, AnUnreachableEndpointIsARefusal) {
  itest::IsolatedEnv env;
  const std::string endpoint = "http://127.0.0.1:" + std::to_string(otest::unused_port());
  cli::Deployment d({openai_planner(endpoint)}, paths::bin_dir(), env.runs / "logs");
  PlannerClient client;
  ASSERT_TRUE(client.ready()) << "the planner never matched";
  client.send(0, "ep-0/p0", "put the bowl on the plate");
  const auto a = client.wait_for("ep-0/p0");
  ASSERT_TRUE(a) << "no advice";
  EXPECT_TRUE(a->refused());
  EXPECT_EQ(a->refusal(), msg::PLANNER_REFUSAL_UNAVAILABLE);
  EXPECT_TRUE(has(a->reason(), endpoint + "/v1/chat/completions")) << a->reason();
  EXPECT_TRUE(has(a->reason(), "cannot connect")) << a->reason();
  EXPECT_TRUE(has(a->reason(), "start the model server")) << a->reason();
  EXPECT_TRUE(d.exited().empty()) << "the planner crashed";
}

TEST(OpenAiPlannerNode, ASlowChannelDoesNotHoldUpTheOthers) {
  itest::IsolatedEnv env;
  otest::FakeOpenAiServer server("valid");
  cli::Deployment d({openai_planner(server.endpoint(), "3")}, paths::bin_dir(), env.runs / "logs");
  PlannerClient client;
  ASSERT_TRUE(client.ready()) << "the planner never matched";
  client.send(1, "slow", "put the bowl on the plate fake-mode:sleep");
  std::this_thread::sleep_for(200ms);
  client.send(2, "fast", "put the bowl on the plate");
  const auto fast = client.wait_for("fast");
  const auto slow = client.wait_for("slow");
  ASSERT_TRUE(fast && slow);
  EXPECT_FALSE(fast->refused()) << fast->reason();
  EXPECT_TRUE(slow->refused());
  EXPECT_TRUE(has(slow->reason(), "no reply")) << slow->reason();
  EXPECT_EQ(client.order(), (std::vector<std::string>{"fast", "slow"}));
}

TEST(OpenAiPlannerNode, ANewerRequestForAChannelSupersedesTheOlder) {
  itest::IsolatedEnv env;
  otest::FakeOpenAiServer server("valid");
  cli::Deployment d({openai_planner(server.endpoint(), "3")}, paths::bin_dir(), env.runs / "logs");
  PlannerClient client;
  ASSERT_TRUE(client.ready()) << "the planner never matched";
  client.send(3, "old", "put the bowl on the plate fake-mode:sleep");
  std::this_thread::sleep_for(300ms);  // in flight
  client.send(3, "new", "put the bowl on the plate");
  const auto a = client.wait_for("new");
  ASSERT_TRUE(a);
  EXPECT_FALSE(a->refused()) << a->reason();
  // The old request's transfer was cancelled: past its 3 s timeout it still has no answer.
  std::this_thread::sleep_for(4s);
  EXPECT_FALSE(client.answered("old"));
  EXPECT_TRUE(d.exited().empty()) << "the planner crashed";
}

TEST(OpenAiPlannerNode, MissingEndpointOrModelIsAStartupError) {
  const auto planner = (paths::bin_dir() / "planner").string();
  auto [out, status] = itest::run_command(planner + " --backend openai --model m 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_TRUE(has(out, "--endpoint URL and --model NAME")) << out;
  std::tie(out, status) = itest::run_command(planner + " --backend gpt 2>&1");
  EXPECT_NE(status, 0);
}

}  // namespace dh
