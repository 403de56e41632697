#include "dh/film/storyboard.hpp"

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <tuple>

#include "dh/common/evidence.hpp"
#include "dh/sim/step_log.hpp"

namespace dh::film {
namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::filesystem::path& f, const std::string& why) {
  throw std::runtime_error(f.string() + ": " + why);
}

// Importance when frames must be dropped; lower is kept first.
enum class Kind { Refused, Recovery, End, Start, CommandEnd, Running };

struct Moment {
  std::uint32_t step;
  Kind kind;
  std::string capability, event;
  std::size_t order = 0;  ///< as it happened: an end before the next start at the same step
};

std::vector<Moment> moments(const Storyboard& s) {
  std::vector<Moment> m;
  for (const auto& c : s.commands) {
    if (c.end_state == "refused") {
      m.push_back({c.end_step, Kind::Refused, c.capability, c.capability + " refused: " + c.end_reason});
      continue;
    }
    m.push_back({c.start_step, c.recovery ? Kind::Recovery : Kind::Start, c.capability,
                 c.capability + (c.recovery ? " starts (recovery)" : " starts")});
    // Its motion: the middle of its actions, or for a long command (60 steps, 3 s) their thirds.
    if (c.first_action_step && *c.last_action_step > *c.first_action_step + 1) {
      const std::uint32_t a = *c.first_action_step, b = *c.last_action_step;
      const std::vector<std::uint32_t> at = b - a >= 60 ? std::vector<std::uint32_t>{a + (b - a) / 3, a + 2 * (b - a) / 3}
                                                        : std::vector<std::uint32_t>{(a + b) / 2};
      for (const std::uint32_t step : at) m.push_back({step, Kind::Running, c.capability, c.capability + " running"});
    }
    if (!c.end_state.empty())
      m.push_back({c.end_step, Kind::CommandEnd, c.capability,
                   c.capability + " " + c.end_state + (c.end_reason.empty() ? "" : ": " + c.end_reason)});
  }
  std::string end = s.latched ? "verdict latched: " + s.outcome : "episode ends: " + s.outcome;
  if (s.latched && s.verdict_step) end += " (held from step " + std::to_string(*s.verdict_step) + ")";
  else if (!s.end_reason.empty()) end += " (" + s.end_reason + ")";
  m.push_back({std::min(s.end_step, s.steps), Kind::End, "", end});
  for (std::size_t i = 0; i < m.size(); ++i) m[i].order = i;
  return m;
}

std::string capability_at(const Storyboard& s, std::uint32_t step) {
  // The command whose action led to the step, else the next one to act (step 0, a refusal's step).
  const auto name = [&](const std::string& id) {
    for (const auto& c : s.commands)
      if (c.id == id) return c.capability;
    return std::string();
  };
  if (step < s.step_command.size() && !s.step_command[step].empty()) return name(s.step_command[step]);
  for (std::size_t i = step + 1; i < s.step_command.size(); ++i)
    if (!s.step_command[i].empty()) return name(s.step_command[i]);
  return "";
}

std::string decision_before(const Storyboard& s, std::uint32_t step) {
  std::string last;
  for (const auto& d : s.decisions)
    if (d.step <= step) last = d.decision;
  return last;
}

// One frame per step: moments at the same step are joined, capabilities in the order they came.
std::vector<Frame> to_frames(const Storyboard& s, std::vector<Moment> picked) {
  std::sort(picked.begin(), picked.end(),
            [](const Moment& a, const Moment& b) { return std::tie(a.step, a.order) < std::tie(b.step, b.order); });
  std::vector<Frame> frames;
  for (const auto& m : picked) {
    if (frames.empty() || frames.back().step != m.step) {
      frames.push_back({m.step, m.capability.empty() ? capability_at(s, m.step) : m.capability, m.event,
                        decision_before(s, m.step)});
      continue;
    }
    Frame& f = frames.back();
    f.event += "; " + m.event;
    const std::string arrow = " -> " + m.capability;
    const bool named = f.capability == m.capability || f.capability.ends_with(arrow);
    if (!m.capability.empty() && !named) f.capability += arrow;
  }
  return frames;
}

}  // namespace

Storyboard read_storyboard(const std::filesystem::path& evidence) {
  if (!std::filesystem::exists(evidence)) bad(evidence, "no such file (an episode's evidence, <episode>.jsonl)");
  const std::vector<json> records = read_evidence(evidence);
  Storyboard s;
  std::map<std::string, std::string> grounded;  // command id -> capability
  bool started = false, ended = false;
  try {
    for (const auto& e : records) {
      const std::string kind = e.value("kind", "");
      const std::uint32_t step = e.value("step", 0u);
      if (kind == "episode_request") {
        s.arm = e.value("arm", "");
      } else if (kind == "episode_start") {
        started = true;
        s.episode_id = e.at("episode_id").get<std::string>();
        s.instruction = e.value("instruction", "");
      } else if (kind == "grounding" && e.value("result", "") == "grounded") {
        grounded[e.at("command_id").get<std::string>()] = e.at("capability").get<std::string>();
      } else if (kind == "decision" && e.value("decision", "") != "continue") {
        s.decisions.push_back({step, e.at("decision").get<std::string>(), e.value("reason", "")});
      } else if (kind == "dispatch") {
        const auto id = e.at("command_id").get<std::string>();
        if (!grounded.count(id)) bad(evidence, "command " + id + " was dispatched without a grounding record");
        CommandSpan c;
        c.id = id;
        c.capability = grounded.at(id);
        c.start_step = step;
        c.recovery = !s.decisions.empty() && s.decisions.back().decision == "insert_recovery";
        s.commands.push_back(std::move(c));
      } else if (kind == "command_status") {
        const std::string state = e.at("state").get<std::string>();
        if (state == "accepted" || state == "running") continue;
        for (auto& c : s.commands)
          if (c.id == e.at("command_id").get<std::string>() && c.end_state.empty()) {
            c.end_state = state;
            c.end_reason = e.value("reason", "");
            c.end_step = step;
          }
      } else if (kind == "episode_end") {
        ended = true;
        s.end_step = step;
        s.outcome = e.value("outcome", "");
        s.end_reason = e.value("reason", "");
        s.latched = e.value("latched", false);
        if (e.contains("verdict_step") && e["verdict_step"].is_number())
          s.verdict_step = e["verdict_step"].get<std::uint32_t>();
      }
    }
  } catch (const json::exception& e) {
    bad(evidence, std::string("a record lacks a field the film needs: ") + e.what());
  }
  if (!started) bad(evidence, "no episode_start record (not a governor's evidence?)");
  if (!ended) bad(evidence, "no episode_end record: the episode was cut before it ended, so there is no verdict to film");

  const auto steps_file = std::filesystem::path(evidence).replace_extension(".steps");
  const sim::StepLog log = sim::read_step_log(steps_file);
  if (log.records.empty()) bad(steps_file, "the step log has no record of step 0");
  s.steps = static_cast<std::uint32_t>(log.records.size() - 1);
  for (const auto& r : log.records) s.step_command.push_back(r.command_id);
  for (std::uint32_t i = 1; i <= s.steps; ++i)
    for (auto& c : s.commands)
      if (c.id == s.step_command[i]) {
        if (!c.first_action_step) c.first_action_step = i;
        c.last_action_step = i;
      }
  return s;
}

std::vector<Frame> auto_frames(const Storyboard& s, std::size_t max_frames) {
  if (max_frames == 0) throw std::invalid_argument("a film needs at least one frame");
  std::vector<Moment> m = moments(s);
  // Moments are dropped by importance, but a step already shown costs no frame.
  std::stable_sort(m.begin(), m.end(), [](const Moment& a, const Moment& b) { return a.kind < b.kind; });
  std::vector<Moment> kept;
  std::vector<std::uint32_t> shown;
  for (const auto& x : m) {
    const bool seen = std::find(shown.begin(), shown.end(), x.step) != shown.end();
    if (!seen && shown.size() == max_frames) continue;
    if (!seen) shown.push_back(x.step);
    kept.push_back(x);
  }
  return to_frames(s, kept);
}

std::vector<Frame> frames_at(const Storyboard& s, const std::vector<std::uint32_t>& steps) {
  std::vector<Moment> all = moments(s), picked;
  std::vector<std::uint32_t> unique = steps;
  std::sort(unique.begin(), unique.end());
  unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
  for (const std::uint32_t step : unique) {
    if (step > s.steps)
      throw std::invalid_argument("step " + std::to_string(step) + " is past the episode's last step (" +
                                  std::to_string(s.steps) + ")");
    bool any = false;
    for (const auto& x : all)
      if (x.step == step) picked.push_back(x), any = true;
    if (!any) picked.push_back({step, Kind::Running, "", ""});
  }
  std::vector<Frame> frames = to_frames(s, picked);
  for (auto& f : frames)
    if (f.event.empty()) f.event = f.capability.empty() ? "no command" : f.capability + " running";
  return frames;
}

std::vector<std::string> caption(const Frame& f) {
  return {"step " + std::to_string(f.step) + (f.capability.empty() ? "" : " | " + f.capability), f.event,
          f.decision.empty() ? "" : "after: " + f.decision};
}

}  // namespace dh::film
