#include "latency.hpp"

#include "dh/common/evidence.hpp"
#include "dh/common/grounding_refusal.hpp"
#include "dh/common/seam_event.hpp"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <map>
#include <stdexcept>

namespace dh::report {

namespace {

constexpr double kNsPerMs = 1e6;

bool has_number(const nlohmann::json& record, const char* key) {
  const auto it = record.find(key);
  return it != record.end() && it->is_number();
}

void read_verdict_end(const nlohmann::json& end, EpisodeTrace& trace) {
  if (const auto o = end.find("oracle"); o != end.end() && o->is_boolean()) trace.oracle_at_end = o->get<bool>();
  trace.unperceived_at_end = end.contains("unperceived");
  const auto terms = end.find("terms");
  if (terms == end.end() || !terms->is_array()) return;
  bool all = true;
  for (const auto& t : *terms) {
    const auto v = t.find("on_true_poses");
    if (v == t.end() || !v->is_boolean()) return;
    all = all && v->get<bool>();
  }
  trace.terms_hold_on_true_poses = all;
}

/// A refusal the evidence records with `code` is the slow brain's own; a code this build does not know is
/// counted with execution's.
bool is_planner_refusal(const std::string& code) {
  const std::optional<Refusal> r = refusal_from_string(code);
  return r && is_planner(*r);
}

}  // namespace

void Latencies::merge(const Latencies& other) {
  decision_ms.insert(decision_ms.end(), other.decision_ms.begin(), other.decision_ms.end());
  planner_ms.insert(planner_ms.end(), other.planner_ms.begin(), other.planner_ms.end());
  unanswered += other.unanswered;
}

void Mechanisms::merge(const Mechanisms& other) {
  episodes += other.episodes;
  for (const auto& [k, n] : other.decisions) decisions[k] += n;
  refusals += other.refusals;
  for (const auto& [c, n] : other.commands) {
    commands[c].first += n.first;
    commands[c].second += n.second;
  }
  for (const auto& [c, n] : other.steps) steps[c] += n;
  safety_holds += other.safety_holds;
  speed_limited += other.speed_limited;
  episodes_held += other.episodes_held;
}

EvidenceStatus collect_evidence(const std::string& path, Latencies& into, Mechanisms& mech, EpisodeTrace& trace) {
  if (path.empty()) return EvidenceStatus::NotRecorded;
  std::vector<nlohmann::json> records;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return EvidenceStatus::Missing;
  try {
    records = read_evidence(path);
  } catch (const std::runtime_error&) {
    return EvidenceStatus::Missing;
  }
  std::map<std::string, std::int64_t> open_requests;  // request_id (dumped) → t_wall_ns of the request
  std::map<std::string, std::string> capability_of;   // command_id → capability
  std::optional<std::pair<std::string, long>> under;  // the capability in control and since which step
  std::map<std::string, double> progress;              // command_id → its highest progress so far
  Mechanisms episode;  // this file's, merged into `mech` once it is read whole
  ++episode.episodes;
  unsigned long holds = 0;
  auto text = [](const nlohmann::json& r, const char* key) {
    const auto it = r.find(key);
    return it != r.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  for (const nlohmann::json& r : records) {
    if (!r.is_object()) continue;
    const std::string kind = text(r, "kind");
    const long step = has_number(r, "step") ? r["step"].get<long>() : -1;
    if (kind == "decision") {
      // A command's progress restarts at its dispatch; a rise over its best so far is progress.
      const std::string id = text(r, "command_id");
      if (has_number(r, "progress") && !id.empty()) {
        const double p = r["progress"].get<double>();
        const auto best = progress.emplace(id, 0.0).first;
        if (p > best->second) {
          best->second = p;
          trace.last_progress_step = step;
        }
      }
      std::string d = text(r, "decision");
      if (d == "request_replan" && text(r, "phase") == "completed") d = "next_step";
      if (!d.empty() && d != "continue") ++episode.decisions[d];
    } else if (kind == "refusal" && !is_planner_refusal(text(r, "refusal"))) {
      ++episode.refusals;  // the planner's own refusals and timeouts are the slow brain's, not execution's
    } else if (kind == "grounding" && text(r, "result") == "grounded") {
      capability_of[text(r, "command_id")] = text(r, "capability");
      ++episode.commands[text(r, "capability")].first;
    } else if ((kind == "dispatch" || kind == "episode_end") && step >= 0) {
      if (kind == "episode_end") trace.end_step = step;
      if (under && step > under->second) episode.steps[under->first] += static_cast<unsigned long>(step - under->second);
      under.reset();
      const auto c = capability_of.find(text(r, "command_id"));
      if (kind == "dispatch" && c != capability_of.end()) under = {{c->second, step}};
    } else if (kind == "command_status") {
      const auto c = capability_of.find(text(r, "command_id"));
      const std::string state = text(r, "state");
      if (c != capability_of.end() && state == "completed") {
        ++episode.commands[c->second].second;
        trace.last_progress_step = std::max(trace.last_progress_step, step);
      }
      if (state == "refused") ++episode.refusals;
    }
    if (kind == "episode_request") {
      trace.robot = text(r, "robot");
    } else if (kind == "episode_start") {
      const auto v = text(r, "verifier");
      trace.verifier = v.empty() ? "oracle" : v;
      if (const auto g = r.find("goal"); g != r.end() && g->is_array())
        for (const auto& term : *g)
          if (term.is_string()) {
            const auto& text = term.get_ref<const std::string&>();
            trace.predicates.push_back(text.substr(0, text.find('(')));
          }
    } else if (kind == "perceived_verdict" && r.value("value", false)) {
      trace.perceived = true;
    } else if (kind == "perceived_verdict_end") {
      if (!trace.perceived) trace.perceived = false;
      read_verdict_end(r, trace);
    }
    if (kind == to_string(SeamEventKind::SafetyHold)) ++holds;
    if (kind == to_string(SeamEventKind::SpeedLimited)) ++episode.speed_limited;
    if (kind == "decision" && has_number(r, "latency_ns")) {
      into.decision_ms.push_back(r["latency_ns"].get<double>() / kNsPerMs);
    } else if ((kind == "plan_request" || kind == "advice") && r.contains("request_id") &&
               has_number(r, "t_wall_ns")) {
      const std::string id = r["request_id"].dump();
      const auto t = r["t_wall_ns"].get<std::int64_t>();
      if (kind == "plan_request") {
        open_requests[id] = t;
      } else if (const auto it = open_requests.find(id); it != open_requests.end()) {
        into.planner_ms.push_back(static_cast<double>(t - it->second) / kNsPerMs);
        open_requests.erase(it);
      }
    }
  }
  into.unanswered += open_requests.size();
  episode.safety_holds += holds;
  episode.episodes_held += holds > 0;
  if (const auto v = episode.steps.find("vla_act"); v != episode.steps.end()) trace.policy_steps = v->second;
  mech.merge(episode);
  return EvidenceStatus::Read;
}

}  // namespace dh::report
