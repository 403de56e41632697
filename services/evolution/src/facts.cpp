#include "dh/evo/facts.hpp"

#include <algorithm>
#include <map>
#include <optional>
#include <stdexcept>

namespace dh::evo {

namespace {

using nlohmann::json;

template <class T>
T field(const json& record, const char* key) {
  const auto it = record.find(key);
  if (it == record.end())
    throw std::runtime_error("evidence record '" + record.value("kind", std::string("?")) + "' (seq " +
                             std::to_string(record.value("seq", -1)) + ") has no '" + key +
                             "' (written by an older build? run the episodes again with this one)");
  return it->get<T>();
}

bool terminal(const std::string& state) {
  return state == "completed" || state == "failed" || state == "refused" || state == "expired" ||
         state == "cancelled";
}

}  // namespace

bool failed(const CommandFacts& c) { return c.state == "failed" || c.state == "refused" || c.state == "expired"; }

EpisodeFacts read_facts(const std::vector<json>& records, bool flagged_infrastructure) {
  EpisodeFacts f;
  f.infrastructure = flagged_infrastructure;
  std::map<std::string, json> grounded;       // command id -> its grounding record
  std::map<std::string, std::size_t> by_id;   // command id -> index in f.commands
  bool recovery_next = false, held = false;
  // The governor moves on without waiting for a stopped command's end: it was preempted.
  const auto preempt_last = [&] {
    if (!f.commands.empty() && !terminal(f.commands.back().state)) f.commands.back().state = "preempted";
  };
  for (const json& r : records) {
    const std::string kind = r.value("kind", "");
    if (kind == "episode_end") {
      preempt_last();
      f.ended = true;
      f.success = field<bool>(r, "success");
      f.outcome = field<std::string>(r, "outcome");
      f.steps = field<std::uint32_t>(r, "step");
      f.latched = r.value("latched", false);
    } else if (kind == "capabilities_missing") {
      f.missing = field<std::vector<std::string>>(r, "missing");
    } else if (kind == "capability_lost") {
      // Lost while it ran this episode's command (not an instance used earlier and since stopped).
      const std::string instance = field<std::string>(r, "instance");
      if (!f.commands.empty() && f.commands.back().instance == instance && !terminal(f.commands.back().state))
        f.capability_lost = true;
    } else if (kind == "deadline_missed") {
      f.missed_waits.push_back(field<std::string>(r, "wait"));
    } else if (kind == "refusal") {
      const std::string code = field<std::string>(r, "refusal");
      const std::optional<Refusal> refusal = refusal_from_string(code);
      if (!refusal)
        throw std::runtime_error("evidence record 'refusal' (seq " + std::to_string(r.value("seq", -1)) +
                                 ") has the unknown code '" + code +
                                 "' (written by another build? run the episodes again with this one)");
      f.refusals.push_back({*refusal, r.value("capability", "")});
    } else if (kind == "grounding" && r.value("result", "") == "grounded") {
      grounded[field<std::string>(r, "command_id")] = r;
    } else if (kind == "dispatch") {
      preempt_last();
      CommandFacts c;
      c.id = field<std::string>(r, "command_id");
      c.instance = field<std::string>(r, "instance");
      c.dispatch_step = field<std::uint32_t>(r, "step");
      c.recovery = recovery_next;
      if (const auto g = grounded.find(c.id); g != grounded.end()) {
        c.capability = g->second.value("capability", "");
        c.args = g->second.value("args", json::object());
      }
      by_id[c.id] = f.commands.size();
      f.commands.push_back(std::move(c));
      recovery_next = false;
    } else if (kind == "decision") {
      const std::string d = field<std::string>(r, "decision");
      recovery_next = d == "insert_recovery";
      f.last_stagnant = r.value("stagnant", 0);
      f.gave_up_on_completion = d == "give_up" && r.value("phase", "") == "completed";
    } else if (kind == "command_status") {
      const auto it = by_id.find(field<std::string>(r, "command_id"));
      if (it == by_id.end()) continue;  // a status of a command this episode did not dispatch
      CommandFacts& c = f.commands[it->second];
      c.state = field<std::string>(r, "state");
      c.failure = r.value("failure", "none");
      c.stage = r.value("stage", "");
      c.end_step = r.value("step", 0u);
    } else if (kind == "advice") {
      f.planner_done = field<bool>(r, "done");
    } else if (kind == "verdict_event") {
      const bool value = field<bool>(r, "value");
      if (value) held = true;
      else if (held) f.verdict_lost = true;
    }
  }
  return f;
}

}  // namespace dh::evo
