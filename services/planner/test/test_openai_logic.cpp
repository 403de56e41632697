// The openai planner backend's pure logic, without a network: the prompt and request body, the reply's
// parsing and validation, the repair request, and every failure turned into a refusal with its reason
// (through a scripted HttpTransport).
#include <gtest/gtest.h>

#include <cstdlib>
#include <deque>
#include <stdexcept>

#include "dh/planner/openai.hpp"

using namespace dh;
using namespace dh::planner;
using nlohmann::json;

namespace {

EntityState entity(const std::string& name, const std::string& kind, std::array<double, 3> p = {},
                   double joint = 0) {
  EntityState e;
  e.name = name;
  e.kind = kind;
  e.p = p;
  e.half_extents = {0.05, 0.04, 0.03};
  e.joint = joint;
  return e;
}

PlanContext kitchen_context() {
  PlanContext c;
  c.instruction = "put the bowl on the plate";
  c.scene = {entity("bowl", "bowl", {-0.17, -0.04, 0.0}), entity("plate", "plate", {-0.2, 0.22, 0.0}),
             entity("cabinet_top_drawer", "drawer", {0.1, 0.3, 0.25}, 0.12),
             entity("stove_knob", "knob", {0.2, -0.3, 0.1}, 0.6)};
  c.capabilities = {"pick_place", "push", "slide_drawer", "keyframe_return", "vla_act"};
  c.history = {"step 0: dispatched push [object=bowl target=plate]",
               "step 12: push refused [object=bowl target=plate]: the jaw is too narrow"};
  return c;
}

CapabilityRoles roles() {
  return {{"pick_place", {"object", "target"}},
          {"push", {"object", "target"}},
          {"slide_drawer", {"drawer", "state:open|closed"}},
          {"vla_act", {"instruction:*"}}};
}

OpenAiConfig config() {
  OpenAiConfig c;
  c.endpoint = "http://127.0.0.1:8000";
  c.model = "qwen3-vl-4b";
  c.timeout = std::chrono::milliseconds(5000);
  return c;
}

std::string completion(const std::string& content, const std::string& finish = "stop") {
  return json({{"id", "x"},
               {"object", "chat.completion"},
               {"choices",
                {{{"index", 0},
                  {"message", {{"role", "assistant"}, {"content", content}}},
                  {"finish_reason", finish}}}}})
      .dump();
}

const std::string kValid =
    R"({"capability":"pick_place","args":{"object":"bowl","target":"plate"},"rationale":"bowl onto plate",)"
    R"("done":false,"refused":false,"reason":"","rest":[{"capability":"slide_drawer","args":{"drawer":"cabinet_top_drawer","state":"closed"}}]})";

/// Replies from a script, records what it was asked.
class ScriptedTransport : public HttpTransport {
 public:
  std::deque<HttpResponse> replies;
  std::vector<HttpRequest> requests;
  HttpResponse post(const HttpRequest& r, const std::function<bool()>&) override {
    requests.push_back(r);
    if (replies.empty()) throw std::runtime_error("script exhausted");
    HttpResponse out = replies.front();
    replies.pop_front();
    return out;
  }
  void ok(const std::string& body, long status = 200) {
    HttpResponse r;
    r.status = status;
    r.body = body;
    replies.push_back(r);
  }
  void fail(HttpResponse::Failure f, const std::string& error) {
    HttpResponse r;
    r.failure = f;
    r.error = error;
    replies.push_back(r);
  }
};

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(OpenAiLogic, CompletionsUrlAppendsThePathOnce) {
  EXPECT_EQ(openai::completions_url("http://127.0.0.1:8000"), "http://127.0.0.1:8000/v1/chat/completions");
  EXPECT_EQ(openai::completions_url("http://127.0.0.1:8000/"), "http://127.0.0.1:8000/v1/chat/completions");
  EXPECT_EQ(openai::completions_url("http://localhost:11434/v1"),
            "http://localhost:11434/v1/chat/completions");
}

TEST(OpenAiLogic, RequestCarriesModelSamplingSchemaAndTheSnapshot) {
  const json r = openai::chat_request(config(), kitchen_context(), roles(), {});
  EXPECT_EQ(r["model"], "qwen3-vl-4b");
  EXPECT_DOUBLE_EQ(r["temperature"].get<double>(), 0.1);
  EXPECT_EQ(r["max_tokens"], 2048);
  EXPECT_EQ(r["response_format"]["type"], "json_schema");
  EXPECT_EQ(r["response_format"]["json_schema"]["name"], "advisory");
  const json& schema = r["response_format"]["json_schema"]["schema"];
  EXPECT_EQ(schema["type"], "object");
  EXPECT_EQ(schema["properties"]["capability"]["enum"],
            json({"pick_place", "push", "slide_drawer", "keyframe_return", "vla_act", ""}));
  for (const char* k : {"capability", "args", "rationale", "done", "refused"})
    EXPECT_NE(std::find(schema["required"].begin(), schema["required"].end(), k), schema["required"].end())
        << k;
  for (const char* k : {"reason", "rest"}) EXPECT_TRUE(schema["properties"].contains(k)) << k;

  ASSERT_EQ(r["messages"].size(), 2u);
  EXPECT_EQ(r["messages"][0]["role"], "system");
  EXPECT_TRUE(has(r["messages"][0]["content"], "never poses"));
  EXPECT_EQ(r["messages"][1]["role"], "user");
  const std::string user = r["messages"][1]["content"];  // a plain string without images
  EXPECT_TRUE(has(user, "Instruction: put the bowl on the plate")) << user;
  EXPECT_TRUE(has(user, "- bowl: bowl at (-0.170, -0.040, 0.000) size (0.100, 0.080, 0.060)")) << user;
  EXPECT_TRUE(has(
      user, "cabinet_top_drawer: drawer at (0.100, 0.300, 0.250) size (0.100, 0.080, 0.060) joint 0.120 m"))
      << user;
  EXPECT_TRUE(has(user, "stove_knob: knob") && has(user, "joint 0.600 rad")) << user;
  EXPECT_FALSE(has(user, "- plate: plate at (-0.200, 0.220, 0.000) size (0.100, 0.080, 0.060) joint"))
      << user;
  EXPECT_TRUE(has(user, "- pick_place(object, target)")) << user;
  EXPECT_TRUE(has(user, "- slide_drawer(drawer, state: open|closed)")) << user;
  EXPECT_TRUE(has(user, "- keyframe_return (arguments not announced)")) << user;
  EXPECT_TRUE(has(user, "- vla_act(instruction: any text)")) << user;
  EXPECT_TRUE(has(user, "- step 12: push refused [object=bowl target=plate]: the jaw is too narrow")) << user;
}

TEST(OpenAiLogic, ACustomSystemPromptReplacesTheBuiltInOne) {
  OpenAiConfig c = config();
  c.system_prompt = "tuned prompt";
  EXPECT_EQ(openai::chat_request(c, kitchen_context(), roles(), {})["messages"][0]["content"],
            "tuned prompt");
}

TEST(OpenAiLogic, EmptySnapshotSaysSo) {
  PlanContext c;
  c.instruction = "do nothing";
  const std::string t = openai::context_text(c, {});
  EXPECT_TRUE(has(t, "(no entities observed)"));
  EXPECT_TRUE(has(t, "Eligible capabilities (argument roles):\n(none)"));
  EXPECT_TRUE(has(t, "(none yet)"));
  EXPECT_EQ(openai::advisory_schema({})["properties"]["capability"]["enum"], json({""}));
}

TEST(OpenAiLogic, Base64MatchesTheRfc4648Vectors) {
  EXPECT_EQ(openai::base64(""), "");
  EXPECT_EQ(openai::base64("f"), "Zg==");
  EXPECT_EQ(openai::base64("fo"), "Zm8=");
  EXPECT_EQ(openai::base64("foo"), "Zm9v");
  EXPECT_EQ(openai::base64("foob"), "Zm9vYg==");
  EXPECT_EQ(openai::base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(openai::base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(openai::base64(std::string("\xff\x00\x10", 3)), "/wAQ");
}

TEST(OpenAiLogic, ImagesBecomeDataUrlPartsAfterTheText) {
  const std::string jpeg("\xFF\xD8\xFF\xE0", 4), png("\x89PNG\r\n\x1a\n", 8);
  const std::vector<EncodedImage> images{
      {"agentview", "", jpeg}, {"wrist", "", png}, {"depth", "image/webp", "x"}};
  const json r = openai::chat_request(config(), kitchen_context(), roles(), images);
  const json& content = r["messages"][1]["content"];
  ASSERT_TRUE(content.is_array());
  ASSERT_EQ(content.size(), 7u);
  EXPECT_EQ(content[0]["type"], "text");
  EXPECT_TRUE(has(content[0]["text"], "put the bowl on the plate"));
  EXPECT_EQ(content[1]["text"], "Camera 'agentview':");
  EXPECT_EQ(content[2]["type"], "image_url");
  EXPECT_EQ(content[2]["image_url"]["url"], "data:image/jpeg;base64," + openai::base64(jpeg));
  EXPECT_EQ(content[4]["image_url"]["url"], "data:image/png;base64," + openai::base64(png));
  EXPECT_EQ(content[6]["image_url"]["url"], "data:image/webp;base64,eA==");
}

TEST(OpenAiLogic, RepairRequestReplaysTheBadReplyAndNamesTheError) {
  const json first = openai::chat_request(config(), kitchen_context(), roles(), {});
  const json r = openai::repair_request(first, "Sure! bowl on plate.", "not JSON: syntax error");
  ASSERT_EQ(r["messages"].size(), 4u);
  EXPECT_EQ(r["messages"][2]["role"], "assistant");
  EXPECT_EQ(r["messages"][2]["content"], "Sure! bowl on plate.");
  EXPECT_EQ(r["messages"][3]["role"], "user");
  EXPECT_TRUE(has(r["messages"][3]["content"], "not JSON: syntax error"));
  EXPECT_TRUE(has(r["messages"][3]["content"], "corrected JSON"));
  EXPECT_EQ(r["response_format"], first["response_format"]);
  EXPECT_EQ(r["temperature"], first["temperature"]);
}

TEST(OpenAiLogic, ReplyContentFromACompletionOrWhyNot) {
  auto c = openai::reply_content(completion("hello", "length"));
  ASSERT_TRUE(c.text);
  EXPECT_EQ(*c.text, "hello");
  EXPECT_EQ(c.finish_reason, "length");

  c = openai::reply_content(
      R"({"choices":[{"message":{"content":[{"type":"text","text":"a"},{"type":"text","text":"b"}]}}]})");
  ASSERT_TRUE(c.text);
  EXPECT_EQ(*c.text, "ab");

  c = openai::reply_content("<html>It works!</html>");
  EXPECT_FALSE(c.text);
  EXPECT_TRUE(has(c.error, "not JSON")) << c.error;
  EXPECT_TRUE(has(openai::reply_content("").error, "empty"));
  EXPECT_TRUE(has(openai::reply_content(R"({"object":"list"})").error, "no choices"));
  EXPECT_TRUE(
      has(openai::reply_content(R"({"error":{"message":"model not found"}})").error, "model not found"));
  EXPECT_TRUE(
      has(openai::reply_content(R"({"choices":[{"message":{"content":null}}]})").error, "no text content"));
  EXPECT_TRUE(has(openai::reply_content(R"({"choices":[{"message":{"content":null,"refusal":"no"}}]})").error,
                  "refused"));
  EXPECT_TRUE(has(openai::reply_content("[1,2]").error, "not a chat completion"));
}

TEST(OpenAiLogic, ValidAdvisoryInEveryArgsForm) {
  const auto caps = kitchen_context().capabilities;
  auto p = openai::parse_advisory(kValid, caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_FALSE(p.advice->refused);
  EXPECT_EQ(p.advice->capability, "pick_place");
  EXPECT_EQ(p.advice->args, (Args{{"object", "bowl"}, {"target", "plate"}}));
  EXPECT_EQ(p.advice->rationale, "bowl onto plate");
  ASSERT_EQ(p.advice->rest.size(), 1u);
  EXPECT_EQ(p.advice->rest[0].capability, "slide_drawer");
  EXPECT_EQ(p.advice->rest[0].args, (Args{{"drawer", "cabinet_top_drawer"}, {"state", "closed"}}));

  for (const char* args : {R"([{"role":"object","entity":"bowl"},{"role":"target","entity":"plate"}])",
                           R"([["object","bowl"],["target","plate"]])"}) {
    const std::string text = std::string(R"({"capability":"push","args":)") + args +
                             R"(,"rationale":"r","done":false,"refused":false})";
    p = openai::parse_advisory(text, caps);
    ASSERT_TRUE(p.advice) << p.error;
    EXPECT_EQ(p.advice->args, (Args{{"object", "bowl"}, {"target", "plate"}})) << args;
  }
  // A free-text argument (vla_act's instruction).
  p = openai::parse_advisory(
      R"({"capability":"vla_act","args":{"instruction":"put the bowl on the plate"},"rationale":"","done":false,"refused":false})",
      caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_EQ(p.advice->args, (Args{{"instruction", "put the bowl on the plate"}}));
  // A capability without arguments.
  p = openai::parse_advisory(
      R"({"capability":"keyframe_return","args":{},"rationale":"","done":false,"refused":false})", caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_TRUE(p.advice->args.empty());
}

TEST(OpenAiLogic, ThinkingAndCodeFencesAroundTheObjectAreTolerated) {
  const auto caps = kitchen_context().capabilities;
  auto p = openai::parse_advisory("<think>the bowl goes on the plate</think>\n```json\n" + kValid + "\n```\n",
                                  caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_EQ(p.advice->capability, "pick_place");
  p = openai::parse_advisory("  \n```\n" + kValid + "```", caps);
  ASSERT_TRUE(p.advice) << p.error;
}

TEST(OpenAiLogic, DoneAndRefusalAreRefusalsWithTheirReason) {
  const auto caps = kitchen_context().capabilities;
  auto p = openai::parse_advisory(
      R"({"capability":"","args":{},"rationale":"all placed","done":true,"refused":false})", caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_TRUE(p.advice->done);
  EXPECT_TRUE(p.advice->refused);
  EXPECT_EQ(p.advice->why, PlannerRefusal::Planning);
  EXPECT_FALSE(p.advice->reason.empty());
  EXPECT_EQ(p.advice->rationale, "all placed");

  p = openai::parse_advisory(
      R"({"capability":"","args":{},"rationale":"","done":false,"refused":true,"reason":"no bowl here"})",
      caps);
  ASSERT_TRUE(p.advice) << p.error;
  EXPECT_TRUE(p.advice->refused);
  EXPECT_FALSE(p.advice->done);
  EXPECT_EQ(p.advice->why, PlannerRefusal::Planning);
  EXPECT_EQ(p.advice->reason, "the model refused: no bowl here");
}

TEST(OpenAiLogic, InvalidRepliesSayWhatIsWrong) {
  const auto caps = kitchen_context().capabilities;
  auto err = [&](const std::string& text) {
    const auto p = openai::parse_advisory(text, caps);
    EXPECT_FALSE(p.advice) << text;
    return p.error;
  };
  EXPECT_TRUE(has(err("Sure! Put the bowl on the plate."), "not JSON"));
  EXPECT_TRUE(has(err(""), "not JSON"));
  EXPECT_TRUE(has(err(R"({"capability":"pick_place")"), "not JSON"));
  EXPECT_TRUE(has(err("[1]"), "schema violation: the reply is an array, not an object"));
  EXPECT_TRUE(
      has(err(R"({"capability":"pick_place","args":42,"rationale":"x"})"), "schema violation: /args"));
  EXPECT_TRUE(has(err(R"({"capability":"pick_place","args":{},"rationale":"x","refused":false})"),
                  "/done is missing"));
  EXPECT_TRUE(has(err(R"({"capability":"pick_place","args":{},"rationale":"x","done":"no","refused":false})"),
                  "/done: expected a boolean, got a string"));
  EXPECT_TRUE(has(
      err(R"({"capability":"pick_place","args":{"object":3},"rationale":"","done":false,"refused":false})"),
      "/args/object entity: expected a string"));
  EXPECT_TRUE(has(
      err(R"({"capability":"pick_place","args":[["object","bowl"],["object","plate"]],"rationale":"","done":false,"refused":false})"),
      "bound twice"));
  EXPECT_TRUE(has(err(R"({"capability":"","args":{},"rationale":"","done":false,"refused":false})"),
                  "/capability is empty"));
  EXPECT_TRUE(has(err(R"({"capability":"","args":{},"rationale":"","done":false,"refused":true})"),
                  "/reason is missing or empty"));
  EXPECT_TRUE(has(
      err(R"({"capability":"pick_place","args":{},"rationale":"","done":false,"refused":false,"rest":[{"args":{}}]})"),
      "/rest/0/capability"));
  const std::string e = err(
      R"({"capability":"teleport","args":{"object":"bowl"},"rationale":"","done":false,"refused":false})");
  EXPECT_TRUE(has(e, "ineligible capability: /capability 'teleport'")) << e;
  EXPECT_TRUE(has(e, "(pick_place, push, slide_drawer, keyframe_return, vla_act)")) << e;
  EXPECT_TRUE(has(
      err(R"({"capability":"push","args":{},"rationale":"","done":false,"refused":false,"rest":[{"capability":"fly","args":{}}]})"),
      "/rest/0/capability 'fly'"));
}

// --- the backend over a scripted transport ---

TEST(OpenAiPlanner, ValidReplyIsTheAdviceInOneRequest) {
  ScriptedTransport http;
  http.ok(completion(kValid));
  const OpenAiPlanner p(config(), http);
  const PlannerAdvice a = p.plan(kitchen_context(), roles(), {});
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  ASSERT_EQ(http.requests.size(), 1u);
  EXPECT_EQ(http.requests[0].url, "http://127.0.0.1:8000/v1/chat/completions");
  EXPECT_LE(http.requests[0].timeout.count(), 5000);
  EXPECT_GT(http.requests[0].timeout.count(), 4000);
  EXPECT_TRUE(http.requests[0].headers.empty()) << "no Authorization without --api-key-env";
  const json body = json::parse(http.requests[0].body);
  EXPECT_EQ(body["max_tokens"], 2048);
}

TEST(OpenAiPlanner, BearerTokenComesFromTheNamedVariableAndNeverShows) {
  setenv("DH_TEST_OPENAI_KEY", "sk-test-123", 1);
  OpenAiConfig c = config();
  c.api_key_env = "DH_TEST_OPENAI_KEY";
  ScriptedTransport http;
  http.ok("{}", 401);
  const OpenAiPlanner p(c, http);
  EXPECT_TRUE(p.key_problem().empty());
  const PlannerAdvice a = p.plan(kitchen_context(), roles(), {});
  ASSERT_EQ(http.requests.size(), 1u);
  EXPECT_EQ(http.requests[0].headers, std::vector<std::string>{"Authorization: Bearer sk-test-123"});
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "HTTP 401")) << a.reason;
  EXPECT_TRUE(has(a.reason, "check the key in DH_TEST_OPENAI_KEY")) << a.reason;
  EXPECT_FALSE(has(a.reason, "sk-test-123"));
  unsetenv("DH_TEST_OPENAI_KEY");
}

TEST(OpenAiPlanner, AnUnsetKeyVariableRefusesWithoutARequest) {
  unsetenv("DH_TEST_OPENAI_MISSING");
  OpenAiConfig c = config();
  c.api_key_env = "DH_TEST_OPENAI_MISSING";
  ScriptedTransport http;
  const OpenAiPlanner p(c, http);
  EXPECT_FALSE(p.key_problem().empty());
  const PlannerAdvice a = p.plan(kitchen_context(), roles(), {});
  EXPECT_TRUE(a.refused);
  EXPECT_EQ(a.why, PlannerRefusal::Unavailable);
  EXPECT_TRUE(has(a.reason, "DH_TEST_OPENAI_MISSING")) << a.reason;
  EXPECT_TRUE(has(a.reason, "127.0.0.1:8000")) << a.reason;
  EXPECT_TRUE(http.requests.empty());
}

TEST(OpenAiPlanner, OneRepairRequestFixesANonJsonReply) {
  ScriptedTransport http;
  http.ok(completion("Sure! Put the bowl on the plate."));
  http.ok(completion(kValid));
  const OpenAiPlanner p(config(), http);
  const PlannerAdvice a = p.plan(kitchen_context(), roles(), {});
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  EXPECT_TRUE(has(a.rationale, "after one repair request"));
  ASSERT_EQ(http.requests.size(), 2u);
  const json repair = json::parse(http.requests[1].body);
  ASSERT_EQ(repair["messages"].size(), 4u);
  EXPECT_EQ(repair["messages"][2]["content"], "Sure! Put the bowl on the plate.");
  EXPECT_TRUE(has(repair["messages"][3]["content"], "not JSON"));
  EXPECT_LE(http.requests[1].timeout, http.requests[0].timeout)
      << "the repair gets what is left of the timeout";
}

TEST(OpenAiPlanner, GivesUpAfterOneRepair) {
  for (const std::string& bad :
       {std::string("still prose"), std::string(R"({"capability":"pick_place","args":42,"rationale":"x"})"),
        std::string(R"({"capability":"teleport","args":{},"rationale":"","done":false,"refused":false})")}) {
    ScriptedTransport http;
    http.ok(completion(bad));
    http.ok(completion(bad));
    const OpenAiPlanner p(config(), http);
    const PlannerAdvice a = p.plan(kitchen_context(), roles(), {});
    EXPECT_TRUE(a.refused) << bad;
    EXPECT_EQ(http.requests.size(), 2u) << bad;
    EXPECT_TRUE(has(a.reason, "http://127.0.0.1:8000/v1/chat/completions")) << a.reason;
    EXPECT_TRUE(has(a.reason, "no usable advisory after one repair request")) << a.reason;
    EXPECT_TRUE(has(a.reason, "structured outputs")) << a.reason;
    const std::string expected = bad[0] == 's'          ? "not JSON"
                                 : has(bad, "teleport") ? "'teleport' is not among the eligible"
                                                        : "schema violation";
    EXPECT_TRUE(has(a.reason, expected)) << a.reason;
    EXPECT_EQ(a.why, has(bad, "teleport") ? PlannerRefusal::Planning : PlannerRefusal::Malformed)
        << "an ineligible capability is the planner's planning, not a reply that cannot be read: " << bad;
  }
}

TEST(OpenAiPlanner, CutRepliesMentionMaxTokens) {
  ScriptedTransport http;
  http.ok(completion(R"({"capability":"pick)", "length"));
  http.ok(completion(R"({"capability":"pick)", "length"));
  const PlannerAdvice a = OpenAiPlanner(config(), http).plan(kitchen_context(), roles(), {});
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "cut at max_tokens 2048")) << a.reason;
}

TEST(OpenAiPlanner, TransportFailuresAreRefusalsThatSayWhatToDo) {
  struct Case {
    HttpResponse::Failure failure;
    std::vector<std::string> expect;
  };
  const std::vector<Case> cases{
      {HttpResponse::Failure::Connect,
       {"cannot connect", "Connection refused", "start the model server", "--endpoint"}},
      {HttpResponse::Failure::Timeout, {"no reply", "--timeout-s", "planner_timeout_ms"}},
      {HttpResponse::Failure::Cancelled, {"cancelled"}},
      {HttpResponse::Failure::Other, {"failed", "--endpoint"}},
  };
  for (const auto& c : cases) {
    ScriptedTransport http;
    http.fail(c.failure, "Connection refused");
    const PlannerAdvice a = OpenAiPlanner(config(), http).plan(kitchen_context(), roles(), {});
    EXPECT_TRUE(a.refused);
    EXPECT_EQ(a.why, PlannerRefusal::Unavailable);
    EXPECT_EQ(http.requests.size(), 1u) << "no repair after a transport failure";
    EXPECT_TRUE(
        has(a.reason, "openai backend at http://127.0.0.1:8000/v1/chat/completions (model 'qwen3-vl-4b')"))
        << a.reason;
    for (const auto& e : c.expect) EXPECT_TRUE(has(a.reason, e)) << a.reason;
  }
}

TEST(OpenAiPlanner, HttpErrorsAndForeignBodiesAreRefusals) {
  auto refuse = [](long status, const std::string& body) {
    ScriptedTransport http;
    http.ok(body, status);
    const PlannerAdvice a = OpenAiPlanner(config(), http).plan(kitchen_context(), roles(), {});
    EXPECT_TRUE(a.refused);
    EXPECT_EQ(a.why, status == 200 ? PlannerRefusal::Malformed : PlannerRefusal::Unavailable)
        << status << " " << body;
    EXPECT_EQ(http.requests.size(), 1u);
    EXPECT_TRUE(has(a.reason, "127.0.0.1:8000")) << a.reason;
    return a.reason;
  };
  std::string r = refuse(500, R"({"error":{"message":"CUDA out of memory"}})");
  EXPECT_TRUE(has(r, "HTTP 500 (CUDA out of memory)")) << r;
  EXPECT_TRUE(has(r, "see its log")) << r;
  r = refuse(404, R"({"detail":"Not Found"})");
  EXPECT_TRUE(has(r, "HTTP 404 (Not Found)") && has(r, "--endpoint") && has(r, "--model")) << r;
  r = refuse(400, "bad request");
  EXPECT_TRUE(has(r, "response_format")) << r;
  r = refuse(401, "");
  EXPECT_TRUE(has(r, "--api-key-env")) << r;
  r = refuse(200, "<html>It works!</html>");
  EXPECT_TRUE(has(r, "not JSON") && has(r, "OpenAI-compatible")) << r;
  r = refuse(200, R"({"data":[]})");
  EXPECT_TRUE(has(r, "not a chat completion")) << r;
}

TEST(OpenAiPlanner, AFailingRepairRequestIsARefusalNamingBoth) {
  ScriptedTransport http;
  http.ok(completion("prose"));
  http.fail(HttpResponse::Failure::Timeout, "Operation timed out");
  const PlannerAdvice a = OpenAiPlanner(config(), http).plan(kitchen_context(), roles(), {});
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "no reply to the repair request")) << a.reason;
  EXPECT_TRUE(has(a.reason, "after a first reply that could not be used: not JSON")) << a.reason;
}

TEST(OpenAiPlanner, NeverThrows) {
  ScriptedTransport http;  // an empty script throws from post()
  const PlannerAdvice a = OpenAiPlanner(config(), http).plan(kitchen_context(), roles(), {});
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(has(a.reason, "internal error: script exhausted")) << a.reason;

  // Invalid UTF-8 in the snapshot does not break serialization, nor the repair request's.
  PlanContext c = kitchen_context();
  c.instruction = "put the \xff bowl";
  c.history.push_back("step 3: \xfe\xfe");
  ScriptedTransport http2;
  http2.ok(completion("not json"));
  http2.ok(completion(kValid));
  const PlannerAdvice b = OpenAiPlanner(config(), http2).plan(c, roles(), {});
  EXPECT_FALSE(b.refused) << b.reason;
}
