#include "dh/planner/openai.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cstdlib>
#include <set>

namespace dh::planner {
namespace openai {
namespace {

using nlohmann::json;

std::string dump(const json& j) { return wire(j); }

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : sep) + s;
  return out;
}

const char* type_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::object:
      return "an object";
    case json::value_t::array:
      return "an array";
    case json::value_t::string:
      return "a string";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "a number";
    default:
      return "an unusable value";
  }
}

json args_schema() {
  const json pair_object = {
      {"type", "object"},
      {"properties", {{"role", {{"type", "string"}}}, {"entity", {{"type", "string"}}}}},
      {"required", {"role", "entity"}},
      {"additionalProperties", false}};
  return {{"anyOf",
           {{{"type", "object"}, {"additionalProperties", {{"type", "string"}}}},
            {{"type", "array"}, {"items", pair_object}},
            {{"type", "array"},
             {"items",
              {{"type", "array"}, {"items", {{"type", "string"}}}, {"minItems", 2}, {"maxItems", 2}}}}}}};
}

/// A schema violation found at a JSON pointer-like path.
struct Violation {
  std::string what;
};

Args parse_args(const json& j, const std::string& path) {
  Args out;
  std::set<std::string> roles;
  auto add = [&](const json& role, const json& entity, const std::string& at) {
    if (!role.is_string()) throw Violation{at + " role: expected a string, got " + type_name(role)};
    if (!entity.is_string()) throw Violation{at + " entity: expected a string, got " + type_name(entity)};
    const auto r = role.get<std::string>();
    const auto e = entity.get<std::string>();
    if (r.empty()) throw Violation{at + ": the role is empty"};
    if (e.empty()) throw Violation{at + ": the entity bound to '" + r + "' is empty"};
    if (!roles.insert(r).second) throw Violation{at + ": the role '" + r + "' is bound twice"};
    out.emplace_back(r, e);
  };
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) add(json(it.key()), it.value(), path + "/" + it.key());
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      const json& p = j[i];
      const std::string at = path + "/" + std::to_string(i);
      if (p.is_object() && p.contains("role") && p.contains("entity"))
        add(p["role"], p["entity"], at);
      else if (p.is_array() && p.size() == 2)
        add(p[0], p[1], at);
      else
        throw Violation{at + ": expected {\"role\": ..., \"entity\": ...} or [role, entity], got " + dump(p)};
    }
  } else {
    throw Violation{path + ": expected an object role -> entity or a list of pairs, got " + type_name(j)};
  }
  return out;
}

std::string strip_wrapping(std::string s) {
  auto trim = [](std::string& t) {
    const auto b = t.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) {
      t.clear();
      return;
    }
    t = t.substr(b, t.find_last_not_of(" \t\r\n") - b + 1);
  };
  trim(s);
  // A reasoning model may think aloud first.
  if (s.rfind("<think>", 0) == 0) {
    const auto end = s.find("</think>");
    if (end != std::string::npos) s = s.substr(end + 8);
    trim(s);
  }
  // A markdown code fence around the object.
  if (s.rfind("```", 0) == 0) {
    const auto nl = s.find('\n');
    const auto close = s.rfind("```");
    if (nl != std::string::npos && close != std::string::npos && close > nl)
      s = s.substr(nl + 1, close - nl - 1);
    trim(s);
  }
  return s;
}

bool is_eligible(const std::vector<std::string>& eligible, const std::string& c) {
  return std::find(eligible.begin(), eligible.end(), c) != eligible.end();
}

std::string not_eligible(const std::string& at, const std::string& c,
                         const std::vector<std::string>& eligible) {
  return "ineligible capability: " + at + " '" + c + "' is not among the eligible capabilities (" +
         (eligible.empty() ? std::string("none") : join(eligible, ", ")) + ")";
}

std::string mime_of(const EncodedImage& image) {
  if (!image.mime.empty()) return image.mime;
  const std::string& b = image.bytes;
  if (b.size() >= 3 && static_cast<unsigned char>(b[0]) == 0xFF && static_cast<unsigned char>(b[1]) == 0xD8 &&
      static_cast<unsigned char>(b[2]) == 0xFF)
    return "image/jpeg";
  if (b.size() >= 8 && b.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0) return "image/png";
  return "application/octet-stream";
}

std::string joint_unit(const std::string& kind) {
  if (kind == "drawer") return "m";
  return "rad";
}

bool articulated(const std::string& kind) { return kind == "drawer" || kind == "knob" || kind == "door"; }

/// "state:open|closed" -> "state: open|closed"; "instruction:*" -> "instruction: any text"; "object" ->
/// "object".
std::string role_text(const std::string& role) {
  const auto colon = role.find(':');
  if (colon == std::string::npos) return role;
  const std::string values = role.substr(colon + 1);
  return role.substr(0, colon) + ": " + (values == "*" ? std::string("any text") : values);
}

}  // namespace

std::string wire(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string completions_url(const std::string& endpoint) {
  std::string e = endpoint;
  while (!e.empty() && e.back() == '/') e.pop_back();
  if (e.size() >= 3 && e.compare(e.size() - 3, 3, "/v1") == 0) return e + "/chat/completions";
  return e + "/v1/chat/completions";
}

std::string default_system_prompt() {
  return R"(You are the slow brain of a robot agent at a tabletop workcell: one arm with a parallel jaw. At each call you read a context snapshot and advise the single next step.

You read:
- the task instruction;
- the scene: every entity by name and kind, with its position and size in metres (world frame at the table centre, z up). Articulated parts (kinds drawer, knob, door) carry their joint value (drawer: metres pulled out; knob, door: radians). Entities of kind region are named places on the table or in fixtures;
- the eligible capabilities: only these can run now, each with its argument roles;
- the history: earlier dispatches and their outcomes (completed, failed, refused, with reasons), oldest first.

You answer with one JSON object and nothing else:
{"capability": "pick_place", "args": {"object": "bowl", "target": "plate"}, "rationale": "one short sentence", "done": false, "refused": false, "reason": "", "rest": [{"capability": "...", "args": {"...": "..."}}]}

The advisory contract:
- capability is exactly one of the eligible capabilities. args binds each of its roles to a scene entity name exactly as listed; a role listed with values (state: open|closed) takes one of those values, a role listed as "any text" takes text (instruction: the words of the step).
- Advise symbols only: never poses, coordinates, trajectories or motions. The fast brain grounds the step, checks its preconditions and executes it; it may refuse it or substitute another capability.
- rest lists the steps that remain after this one, in order (empty when this is the last).
- Do not advise again a step the history shows completed with the same arguments. Do not repeat unchanged a step that was refused or failed; choose other arguments or another eligible capability when its reason suggests one.
- When the history shows every step of the instruction completed, answer done=true with capability "" and args {}.
- When the instruction cannot be carried out with the eligible capabilities in this scene, answer refused=true with capability "", args {} and the reason.)";
}

json advisory_schema(const std::vector<std::string>& eligible) {
  json capabilities = json::array();
  for (const auto& c : eligible)
    if (!c.empty() && std::find(capabilities.begin(), capabilities.end(), c) == capabilities.end())
      capabilities.push_back(c);  // enum values must be unique
  json with_empty = capabilities;
  with_empty.push_back("");
  const json step = {
      {"type", "object"},
      {"properties", {{"capability", {{"type", "string"}, {"enum", capabilities}}}, {"args", args_schema()}}},
      {"required", {"capability", "args"}},
      {"additionalProperties", false}};
  return {{"type", "object"},
          {"properties",
           {{"capability", {{"type", "string"}, {"enum", with_empty}}},
            {"args", args_schema()},
            {"rationale", {{"type", "string"}}},
            {"done", {{"type", "boolean"}}},
            {"refused", {{"type", "boolean"}}},
            {"reason", {{"type", "string"}}},
            {"rest", {{"type", "array"}, {"items", step}}}}},
          {"required", {"capability", "args", "rationale", "done", "refused"}},
          {"additionalProperties", false}};
}

std::string context_text(const PlanContext& ctx, const CapabilityRoles& roles) {
  std::string out = "Instruction: " + ctx.instruction + "\n\n";
  out += "Scene (name: kind, position x y z, size x y z, in m; articulated parts with their joint value):\n";
  if (ctx.scene.empty()) out += "(no entities observed)\n";
  for (const auto& e : ctx.scene) {
    out += fmt::format("- {}: {} at ({:.3f}, {:.3f}, {:.3f}) size ({:.3f}, {:.3f}, {:.3f})", e.name, e.kind,
                       e.p[0], e.p[1], e.p[2], 2 * e.half_extents[0], 2 * e.half_extents[1],
                       2 * e.half_extents[2]);
    if (articulated(e.kind)) out += fmt::format(" joint {:.3f} {}", e.joint, joint_unit(e.kind));
    out += "\n";
  }
  out += "\nEligible capabilities (argument roles):\n";
  if (ctx.capabilities.empty()) out += "(none)\n";
  for (const auto& c : ctx.capabilities) {
    const auto it = roles.find(c);
    if (it == roles.end()) {
      out += "- " + c + " (arguments not announced)\n";
      continue;
    }
    std::vector<std::string> r;
    for (const auto& role : it->second) r.push_back(role_text(role));
    out += "- " + c + "(" + join(r, ", ") + ")\n";
  }
  out += "\nHistory (oldest first):\n";
  if (ctx.history.empty()) out += "(none yet)\n";
  for (const auto& h : ctx.history) out += "- " + h + "\n";
  out += "\nAnswer with the JSON advisory for the next step.";
  return out;
}

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 |
                       static_cast<unsigned char>(bytes[i + 1]) << 8 |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1])
                                                                        << 8;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += '=';
  }
  return out;
}

std::string data_url(const EncodedImage& image) {
  return "data:" + mime_of(image) + ";base64," + base64(image.bytes);
}

json chat_request(const OpenAiConfig& config, const PlanContext& ctx, const CapabilityRoles& roles,
                  const std::vector<EncodedImage>& images) {
  const std::string text = context_text(ctx, roles);
  json user;
  if (images.empty()) {
    user = text;  // a plain string: text-only servers accept it too
  } else {
    user = json::array({{{"type", "text"}, {"text", text}}});
    for (const auto& im : images) {
      user.push_back({{"type", "text"}, {"text", "Camera '" + im.camera + "':"}});
      user.push_back({{"type", "image_url"}, {"image_url", {{"url", data_url(im)}}}});
    }
  }
  return {{"model", config.model},
          {"messages",
           {{{"role", "system"},
             {"content", config.system_prompt.empty() ? default_system_prompt() : config.system_prompt}},
            {{"role", "user"}, {"content", user}}}},
          {"temperature", config.temperature},
          {"max_tokens", config.max_tokens},
          {"stream", false},
          {"response_format",
           {{"type", "json_schema"},
            {"json_schema", {{"name", "advisory"}, {"schema", advisory_schema(ctx.capabilities)}}}}}};
}

json repair_request(const json& request, const std::string& bad_reply, const std::string& error) {
  json r = request;
  r["messages"].push_back({{"role", "assistant"}, {"content", bad_reply}});
  r["messages"].push_back(
      {{"role", "user"},
       {"content", "Your reply cannot be used: " + error +
                       ". Answer again with only one corrected JSON object that follows the advisory schema "
                       "(capability, args, rationale, done, refused, reason, rest), and nothing else."}});
  return r;
}

ReplyContent reply_content(const std::string& body) {
  ReplyContent out;
  json j;
  try {
    j = json::parse(body);
  } catch (const json::exception&) {
    out.error =
        "the response body is not JSON (" + (body.empty() ? std::string("empty") : snippet(body)) + ")";
    return out;
  }
  if (!j.is_object()) {
    out.error = "the response body is " + std::string(type_name(j)) + ", not a chat completion";
    return out;
  }
  if (j.contains("error")) {
    const json& e = j["error"];
    out.error =
        "the server answered an error: " + (e.is_object() && e.contains("message") && e["message"].is_string()
                                                ? e["message"].get<std::string>()
                                                : snippet(dump(e)));
    return out;
  }
  if (!j.contains("choices") || !j["choices"].is_array() || j["choices"].empty() ||
      !j["choices"][0].is_object()) {
    out.error = "the response is not a chat completion (no choices): " + snippet(dump(j));
    return out;
  }
  const json& choice = j["choices"][0];
  if (choice.contains("finish_reason") && choice["finish_reason"].is_string())
    out.finish_reason = choice["finish_reason"].get<std::string>();
  if (!choice.contains("message") || !choice["message"].is_object()) {
    out.error = "the completion has no message: " + snippet(dump(choice));
    return out;
  }
  const json& message = choice["message"];
  const json content = message.value("content", json());
  if (content.is_string()) {
    out.text = content.get<std::string>();
  } else if (content.is_array()) {  // a list of content parts
    std::string text;
    for (const auto& part : content)
      if (part.is_object() && part.value("type", "") == "text" && part.contains("text") &&
          part["text"].is_string())
        text += part["text"].get<std::string>();
    out.text = text;
  } else if (message.contains("refusal") && message["refusal"].is_string()) {
    out.error = "the model refused to answer: " + message["refusal"].get<std::string>();
    out.model_refused = true;
  } else {
    out.error = "the completion's message has no text content: " + snippet(dump(message));
  }
  return out;
}

ParsedAdvisory parse_advisory(const std::string& content, const std::vector<std::string>& eligible) {
  ParsedAdvisory out;
  const std::string text = strip_wrapping(content);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    // "[json.exception.parse_error.101] parse error at line 1, column 1: ...; last read: ..." -> the middle.
    std::string what = e.what();
    if (const auto b = what.find("] "); b != std::string::npos) what = what.substr(b + 2);
    if (const auto l = what.find("; last read"); l != std::string::npos) what.resize(l);
    out.error = "not JSON (" + (text.empty() ? std::string("an empty reply") : what) + ")";
    return out;
  }
  try {
    if (!j.is_object()) throw Violation{"the reply is " + std::string(type_name(j)) + ", not an object"};
    auto field = [&](const char* key, json::value_t type, const char* type_text) -> const json* {
      if (!j.contains(key)) return nullptr;
      const json& v = j[key];
      const bool ok = v.type() == type;
      if (!ok) throw Violation{std::string("/") + key + ": expected " + type_text + ", got " + type_name(v)};
      return &v;
    };
    auto required = [&](const char* key, json::value_t type, const char* type_text) -> const json& {
      const json* v = field(key, type, type_text);
      if (!v) throw Violation{std::string("/") + key + " is missing"};
      return *v;
    };
    PlannerAdvice a;
    a.capability = required("capability", json::value_t::string, "a string").get<std::string>();
    if (!j.contains("args")) throw Violation{"/args is missing"};
    a.args = parse_args(j["args"], "/args");
    a.rationale = required("rationale", json::value_t::string, "a string").get<std::string>();
    a.done = required("done", json::value_t::boolean, "a boolean").get<bool>();
    const bool refused = required("refused", json::value_t::boolean, "a boolean").get<bool>();
    const json* reason = field("reason", json::value_t::string, "a string");
    const std::string why = reason ? reason->get<std::string>() : "";
    if (const json* rest = field("rest", json::value_t::array, "an array")) {
      for (std::size_t i = 0; i < rest->size(); ++i) {
        const json& s = (*rest)[i];
        const std::string at = "/rest/" + std::to_string(i);
        if (!s.is_object()) throw Violation{at + ": expected an object, got " + type_name(s)};
        if (!s.contains("capability") || !s["capability"].is_string())
          throw Violation{at + "/capability: expected a string"};
        if (!s.contains("args")) throw Violation{at + "/args is missing"};
        a.rest.push_back({s["capability"].get<std::string>(), parse_args(s["args"], at + "/args")});
      }
    }
    if (a.done) {
      a.refused = true;  // as the rules backend: done is a refusal that says every step completed
      a.why = PlannerRefusal::Planning;
      a.reason = why.empty() ? "the model judges every step of the instruction completed" : why;
      a.capability.clear();
      a.args.clear();
      a.rest.clear();
    } else if (refused) {
      if (why.empty()) throw Violation{"/reason is missing or empty while refused is true"};
      a.refused = true;
      a.why = PlannerRefusal::Planning;
      a.reason = "the model refused: " + why;
      a.capability.clear();
      a.args.clear();
      a.rest.clear();
    } else {
      if (a.capability.empty())
        throw Violation{"/capability is empty while neither done nor refused is true"};
      if (!is_eligible(eligible, a.capability)) {
        out.error = not_eligible("/capability", a.capability, eligible);
        out.ineligible = true;
        return out;
      }
      for (std::size_t i = 0; i < a.rest.size(); ++i) {
        if (!is_eligible(eligible, a.rest[i].capability)) {
          out.error =
              not_eligible("/rest/" + std::to_string(i) + "/capability", a.rest[i].capability, eligible);
          out.ineligible = true;
          return out;
        }
      }
    }
    out.advice = std::move(a);
  } catch (const Violation& v) {
    out.error = "schema violation: " + v.what;
  }
  return out;
}

std::string snippet(std::string_view text, std::size_t max) {
  std::string out;
  out.reserve(std::min(text.size(), max) + 3);
  for (const char c : text.substr(0, max)) out += (c == '\n' || c == '\r' || c == '\t') ? ' ' : c;
  if (text.size() > max) out += "...";
  return out;
}

}  // namespace openai

namespace {

using nlohmann::json;

std::string seconds(std::chrono::milliseconds ms) { return fmt::format("{:.3g} s", ms.count() / 1000.0); }

PlannerAdvice refusal(PlannerRefusal why, std::string reason) {
  PlannerAdvice a;
  a.refused = true;
  a.why = why;
  a.reason = std::move(reason);
  return a;
}

/// The message an error body carries ({"error": {"message": ...}}, {"detail": ...}, {"message": ...}),
/// else the body itself, cut short.
std::string error_text(const std::string& body) {
  const json j = json::parse(body, nullptr, false);
  if (j.is_object()) {
    if (j.contains("error")) {
      const json& e = j["error"];
      if (e.is_string()) return openai::snippet(e.get<std::string>());
      if (e.is_object() && e.contains("message") && e["message"].is_string())
        return openai::snippet(e["message"].get<std::string>());
    }
    for (const char* key : {"detail", "message"})
      if (j.contains(key) && j[key].is_string()) return openai::snippet(j[key].get<std::string>());
  }
  return body.empty() ? "empty body" : openai::snippet(body);
}

}  // namespace

OpenAiPlanner::OpenAiPlanner(OpenAiConfig config, HttpTransport& http)
    : config_(std::move(config)), http_(http), url_(openai::completions_url(config_.endpoint)) {
  if (!config_.api_key_env.empty()) {
    const char* key = std::getenv(config_.api_key_env.c_str());
    if (key && *key)
      headers_.push_back(std::string("Authorization: Bearer ") + key);
    else
      key_problem_ =
          "the environment variable " + config_.api_key_env +
          " named by --api-key-env is not set or empty: set it in the planner's environment, or drop "
          "--api-key-env when the server needs no key";
  }
}

PlannerAdvice OpenAiPlanner::plan(const PlanContext& ctx, const CapabilityRoles& roles,
                                  const std::vector<EncodedImage>& images,
                                  const std::function<bool()>& cancelled) const {
  try {
    return plan_or_refuse(ctx, roles, images, cancelled);
  } catch (const std::exception& e) {
    return refusal(PlannerRefusal::Unavailable,
                   "openai backend at " + url_ + ": internal error: " + e.what() + "; please report it");
  }
}

PlannerAdvice OpenAiPlanner::plan_or_refuse(const PlanContext& ctx, const CapabilityRoles& roles,
                                            const std::vector<EncodedImage>& images,
                                            const std::function<bool()>& cancelled) const {
  const std::string at = "openai backend at " + url_ + " (model '" + config_.model + "'): ";
  if (!key_problem_.empty()) return refusal(PlannerRefusal::Unavailable, at + key_problem_);
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + config_.timeout;

  // One round trip. Returns a final advice (valid or refusal), or sets `repairable` to the reason the
  // model's content cannot be used, with the content in `bad`.
  enum class Outcome { Final, Repairable };
  PlannerAdvice final;
  std::string repairable, bad, finish;
  bool ineligible = false;  // what `repairable` says is an ineligible capability, not a malformed reply
  auto attempt = [&](const json& body, const char* which) -> Outcome {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) {
      final = refusal(PlannerRefusal::Unavailable,
                      at + "no time left for the " + which + " within the " + seconds(config_.timeout) +
                          " timeout; raise --timeout-s (and the governor's planner_timeout_ms above it)");
      return Outcome::Final;
    }
    const HttpResponse r = http_.post({url_, openai::wire(body), headers_, left}, cancelled);
    switch (r.failure) {
      case HttpResponse::Failure::Connect:
        final = refusal(
            PlannerRefusal::Unavailable,
            at + "cannot connect for the " + which + " (" + r.error +
                "): start the model server (vLLM, llama.cpp, Ollama) there or point --endpoint at it");
        return Outcome::Final;
      case HttpResponse::Failure::Timeout:
        final = refusal(
            PlannerRefusal::Unavailable,
            at + "no reply to the " + which + " within " +
                (std::string(which) == "request"
                     ? "the " + seconds(config_.timeout) + " timeout"
                     : "the " + seconds(left) + " left of the " + seconds(config_.timeout) + " timeout") +
                ": the server is overloaded or the model too slow; raise --timeout-s (and the governor's "
                "planner_timeout_ms above it) or serve a smaller model");
        return Outcome::Final;
      case HttpResponse::Failure::Cancelled:
        final = refusal(
            PlannerRefusal::Unavailable,
            at + "the " + std::string(which) +
                " was cancelled (a newer request for the channel arrived, or the planner is stopping)");
        return Outcome::Final;
      case HttpResponse::Failure::Other:
        final = refusal(PlannerRefusal::Unavailable,
                        at + "the " + std::string(which) + " failed (" + r.error +
                            "): check --endpoint (http://host:port of an OpenAI-compatible server)");
        return Outcome::Final;
      case HttpResponse::Failure::None:
        break;
    }
    if (r.status < 200 || r.status >= 300) {
      std::string todo;
      if (r.status == 401 || r.status == 403)
        todo = config_.api_key_env.empty()
                   ? "the server wants a key: pass --api-key-env VAR with the key in VAR"
                   : "check the key in " + config_.api_key_env;
      else if (r.status == 404)
        todo = "check --endpoint (the server's root; /v1/chat/completions is appended) and --model";
      else if (r.status == 400 || r.status == 422)
        todo = "check --model, and that the server accepts response_format json_schema (structured outputs)" +
               std::string(images.empty() ? "" : " and images (a vision model)");
      else if (r.status == 429 || r.status == 503)
        todo = "the server is overloaded; fewer channels or more server capacity";
      else if (r.status >= 500)
        todo = "the model server failed; see its log";
      else
        todo = "check --endpoint";
      final = refusal(PlannerRefusal::Unavailable, at + "the " + std::string(which) + " got HTTP " +
                                                       std::to_string(r.status) + " (" + error_text(r.body) +
                                                       "): " + todo);
      return Outcome::Final;
    }
    const openai::ReplyContent content = openai::reply_content(r.body);
    if (!content.text) {
      final = refusal(content.model_refused ? PlannerRefusal::Planning : PlannerRefusal::Malformed,
                      at + "unusable reply to the " + which + ": " + content.error +
                          "; check that --endpoint is an OpenAI-compatible chat-completions server");
      return Outcome::Final;
    }
    openai::ParsedAdvisory parsed = openai::parse_advisory(*content.text, ctx.capabilities);
    if (parsed.advice) {
      final = std::move(*parsed.advice);
      return Outcome::Final;
    }
    repairable = parsed.error;
    ineligible = parsed.ineligible;
    if (content.finish_reason == "length")
      repairable += " (the reply was cut at max_tokens " + std::to_string(config_.max_tokens) + ")";
    bad = *content.text;
    return Outcome::Repairable;
  };

  const json request = openai::chat_request(config_, ctx, roles, images);
  if (attempt(request, "request") == Outcome::Final) return final;
  const std::string first_error = repairable, first_reply = bad;
  if (attempt(openai::repair_request(request, first_reply, first_error), "repair request") ==
      Outcome::Final) {
    if (final.refused && !final.done && final.reason.rfind(at, 0) == 0)
      final.reason += " (after a first reply that could not be used: " + first_error + ")";
    else if (!final.refused)
      final.rationale +=
          final.rationale.empty() ? "(after one repair request)" : " (after one repair request)";
    return final;
  }
  return refusal(
      ineligible ? PlannerRefusal::Planning : PlannerRefusal::Malformed,
      at + "no usable advisory after one repair request: " + repairable +
          (repairable == first_error ? std::string(", as in the first reply")
                                     : "; the first reply: " + first_error) +
          " (last reply: '" + openai::snippet(bad, 120) +
          "'); the server may ignore response_format (enable structured outputs, e.g. vLLM's xgrammar or "
          "llama-server's json_schema) or the model does not follow the schema");
}

}  // namespace dh::planner
