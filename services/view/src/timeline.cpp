#include "dh/view/timeline.hpp"

#include <map>
#include <stdexcept>

#include "dh/common/evidence.hpp"
#include "dh/evo/attribution.hpp"
#include "dh/evo/facts.hpp"

namespace dh::view {

using nlohmann::json;

namespace {

// The fields of `r` named in `keys` that it has.
json pick(const json& r, std::initializer_list<const char*> keys) {
  json out = json::object();
  for (const char* k : keys)
    if (r.contains(k)) out[k] = r[k];
  return out;
}

}  // namespace

json episode_timeline(const std::filesystem::path& evidence, const std::filesystem::path& attribution_config) {
  if (!std::filesystem::is_regular_file(evidence))
    throw std::runtime_error(evidence.string() + ": no such evidence file (runs/evidence/<episode>.jsonl on the "
                             "governor's host)");
  const std::vector<json> records = read_evidence(evidence);
  if (records.empty()) throw std::runtime_error(evidence.string() + ": holds no complete record");
  json page{{"evidence", evidence.string()}, {"attribution", nullptr}, {"verdict_step", nullptr}};
  json events = json::array();
  std::map<std::string, std::string> capability_of;  // command id -> capability
  unsigned holds = 0;
  bool started = false;
  for (const json& r : records) {
    if (!r.is_object()) continue;
    const std::string kind = r.value("kind", "");
    const json step = r.value("step", json(nullptr));
    json e{{"step", step}};
    if (kind == "episode_request") {
      page.update(pick(r, {"arm", "cell", "suite", "task", "seed"}));
    } else if (kind == "episode_start") {
      started = true;
      page.update(pick(r, {"episode_id", "instruction", "budget_steps", "library_version", "channel"}));
    } else if (kind == "advice") {
      e.update(pick(r, {"capability", "args", "done", "refused", "reason", "rationale", "backend"}));
      e["kind"] = "advice";
    } else if (kind == "grounding") {
      if (r.value("result", "") == "grounded") capability_of[r.value("command_id", "")] = r.value("capability", "");
      e.update(pick(r, {"capability", "command_id", "args", "theta", "version", "instance", "result", "reason"}));
      e["kind"] = r.value("result", "") == "grounded" ? "grounding" : "refusal";
    } else if (kind == "refusal") {
      e.update(pick(r, {"refusal", "reason", "in_row"}));
      e["kind"] = "refusal";
    } else if (kind == "dispatch") {
      e.update(pick(r, {"command_id", "instance", "budget_steps"}));
      e["capability"] = capability_of[r.value("command_id", "")];
      e["kind"] = "dispatch";
    } else if (kind == "command_status") {
      const std::string state = r.value("state", "");
      if (state == "accepted" || state == "running") continue;
      e.update(pick(r, {"command_id", "state", "failure", "stage", "reason", "steps_used"}));
      e["capability"] = capability_of[r.value("command_id", "")];
      e["kind"] = state == "refused" ? "refusal" : "command_end";
    } else if (kind == "decision") {
      if (r.value("decision", "") == "continue") continue;
      e.update(pick(r, {"decision", "reason", "capability", "cause", "latency_ns"}));
      e["kind"] = "decision";
    } else if (kind == "verdict_event") {
      e.update(pick(r, {"predicate", "value"}));
      e["kind"] = "verdict";
    } else if (kind == "episode_end") {
      page.update(pick(r, {"outcome", "reason", "success", "latched", "verdict_step"}));
      page["end_step"] = step;
      e.update(pick(r, {"outcome", "reason", "latched"}));
      e["kind"] = "end";
    } else {
      if (kind == "safety_hold") ++holds;
      continue;
    }
    if (e.contains("kind")) events.push_back(std::move(e));
  }
  if (!started) throw std::runtime_error(evidence.string() + ": no episode_start record (not a governor's evidence?)");
  page["events"] = std::move(events);
  page["safety_holds"] = holds;
  if (page.contains("success") && page["success"] == false && !attribution_config.empty()) {
    try {
      const auto label = evo::attribute(evo::read_facts(records), evo::load_attribution(attribution_config));
      if (label)
        page["attribution"] = {{"layer", label->layer}, {"name", label->name}, {"harness", label->harness},
                               {"capability", label->signature.capability}, {"failure", label->signature.failure},
                               {"stage", label->signature.stage}, {"step", label->signature.step}};
      else
        page["attribution"] = {{"error", "no attribution layer matched this episode"}};
    } catch (const std::exception& ex) {
      page["attribution"] = {{"error", ex.what()}};
    }
  }
  return page;
}

}  // namespace dh::view
