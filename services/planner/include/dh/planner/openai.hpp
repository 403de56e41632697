// The `openai` slow-brain backend: a client for any OpenAI-compatible chat-completions endpoint (vLLM,
// llama.cpp's llama-server, Ollama), e.g. Qwen3-VL-4B served locally.
//
// Everything here is pure and runs without a network: the prompt (a system message stating the advisory
// contract and a user message with the context snapshot, optionally with camera images as data-URL
// parts), the request body with its JSON schema for structured outputs, the parsing and validation of
// the reply, and the one serialization-repair request. The HTTP round trip goes through HttpTransport
// (http.hpp: the libcurl transport the node uses; tests script their own).
//
// Every failure becomes a refusal whose reason names the endpoint, what went wrong and what to do; the
// governor records it and replans or gives up. OpenAiPlanner::plan never throws and never waits longer
// than the configured timeout (the repair request gets what is left of it).
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dh/planner/http.hpp"
#include "dh/planner/rules.hpp"

namespace dh::planner {

/// One encoded camera image for a vision-language model: the file's bytes (JPEG or PNG), not pixels.
struct EncodedImage {
  std::string camera;  ///< camera name, e.g. "agentview"
  std::string mime;    ///< "image/jpeg", "image/png"; empty: taken from the bytes' signature
  std::string bytes;
};

struct OpenAiConfig {
  std::string endpoint;  ///< server root, e.g. http://127.0.0.1:8000 (/v1/chat/completions is appended)
  std::string model;
  double temperature = 0.1;
  int max_tokens = 2048;
  std::chrono::milliseconds timeout{90000};  ///< whole plan() call, the repair request included
  std::string api_key_env;    ///< environment variable holding a bearer token ("" = no Authorization)
  std::string system_prompt;  ///< "" = openai::default_system_prompt()
};

namespace openai {

/// "{endpoint}/v1/chat/completions" (a trailing slash of the endpoint is dropped; an endpoint that
/// already ends in /v1 gets only /chat/completions).
std::string completions_url(const std::string& endpoint);

/// The advisory contract: what the slow brain reads, what it answers, and the reply's JSON form.
std::string default_system_prompt();

/// JSON schema of the advisory: capability (one of `eligible`, or "" with done or refused), args (an
/// object role -> entity, or a list of {"role", "entity"} objects or [role, entity] pairs), rationale,
/// done, refused, reason, rest (later steps: capability and args).
nlohmann::json advisory_schema(const std::vector<std::string>& eligible);

/// The context snapshot as the user message's text: instruction, scene entities (kind, position, size,
/// joint value of articulated parts), eligible capabilities with their roles where known, history.
std::string context_text(const PlanContext& ctx, const CapabilityRoles& roles);

/// "data:image/jpeg;base64,..."; the mime from `image.mime` or, when empty, from the bytes' signature.
std::string data_url(const EncodedImage& image);
std::string base64(std::string_view bytes);

/// The chat-completions request body: model, messages (system + user, with one image_url part per
/// image), temperature, max_tokens and response_format {"type":"json_schema","json_schema":{...}}.
nlohmann::json chat_request(const OpenAiConfig& config, const PlanContext& ctx, const CapabilityRoles& roles,
                            const std::vector<EncodedImage>& images);

/// The serialization-repair request: the first request's messages, the bad reply as the assistant's
/// turn and a user turn naming the error and asking for one corrected JSON object.
nlohmann::json repair_request(const nlohmann::json& request, const std::string& bad_reply,
                              const std::string& error);

/// The assistant's content of a chat-completions response body, or why there is none.
struct ReplyContent {
  std::optional<std::string> text;
  std::string error;          ///< set when text is empty: the body is not JSON, not a completion, ...
  bool model_refused = false;  ///< the error is the model's own refusal (the message's `refusal`)
  std::string finish_reason;  ///< "stop", "length", ... as the server gave it
};
ReplyContent reply_content(const std::string& body);

/// The model's content parsed and checked against the schema and the eligible capabilities. Tolerates
/// whitespace, a markdown code fence and a leading <think>...</think> block around the object.
struct ParsedAdvisory {
  std::optional<PlannerAdvice> advice;
  std::string error;  ///< set when advice is empty: "not JSON: ...", "schema: /args/object: ...", ...
  bool ineligible =
      false;  ///< the error is a capability that is not eligible (a planning error, not a malformed reply)
};
ParsedAdvisory parse_advisory(const std::string& content, const std::vector<std::string>& eligible);

/// `j` as sent: compact, invalid UTF-8 (model replies and scene names are not ours) replaced, never a throw.
std::string wire(const nlohmann::json& j);

/// `text` cut to `max` characters with "..." when longer, newlines flattened (for reasons and logs).
std::string snippet(std::string_view text, std::size_t max = 240);

}  // namespace openai

/// The backend: one chat-completions request per plan request, one repair request when the reply is not
/// a valid advisory, a refusal with its reason for everything that goes wrong.
class OpenAiPlanner {
 public:
  /// Reads the bearer token from `config.api_key_env` once, here; a named variable that is unset makes
  /// every advice a refusal saying so (the key itself never appears in reasons or logs).
  OpenAiPlanner(OpenAiConfig config, HttpTransport& http);

  /// Never throws. `cancelled` is polled during transfers (a newer request for the channel, shutdown).
  PlannerAdvice plan(const PlanContext& ctx, const CapabilityRoles& roles,
                     const std::vector<EncodedImage>& images,
                     const std::function<bool()>& cancelled = {}) const;

  const OpenAiConfig& config() const { return config_; }
  const std::string& url() const { return url_; }
  /// "" when the token is usable or none is asked for; otherwise why not.
  const std::string& key_problem() const { return key_problem_; }

 private:
  PlannerAdvice plan_or_refuse(const PlanContext& ctx, const CapabilityRoles& roles,
                               const std::vector<EncodedImage>& images,
                               const std::function<bool()>& cancelled) const;

  OpenAiConfig config_;
  HttpTransport& http_;
  std::string url_;
  std::vector<std::string> headers_;
  std::string key_problem_;
};

}  // namespace dh::planner
