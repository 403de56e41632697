#include "dh/inproc/recording.hpp"

#include <mujoco/mujoco.h>

#include "dh/common/evidence.hpp"
#include "dh/inproc/bus.hpp"

namespace dh::inproc {
namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::filesystem::path& evidence, const std::string& what) {
  throw EvidenceError("evidence " + evidence.string() + ": " + what);
}

std::string joint_name(const mjModel* m, int j) {
  const char* n = mj_id2name(m, mjOBJ_JOINT, j);
  return n ? n : "joint" + std::to_string(j);
}

std::string body_name(const mjModel* m, int b) {
  const char* n = mj_id2name(m, mjOBJ_BODY, b);
  return n ? n : "body" + std::to_string(b);
}

}  // namespace

Divergence divergence_at(const sim::Workcell& cell, std::uint32_t step, const sim::StateDigest& want) {
  const mjModel* m = cell.model();
  const sim::StateDigest got = cell.digest();
  for (std::size_t i = 0; i < got.joints.size() && i < want.joints.size(); ++i)
    if (got.joints[i] != want.joints[i]) {
      const int j = static_cast<int>(i / 2);
      return {step, body_name(m, m->jnt_bodyid[j]),
              std::string(i % 2 ? "qvel:" : "qpos:") + joint_name(m, j)};
    }
  static const char* aux[] = {"time", "act", "ctrl", "qacc_warmstart"};
  for (std::size_t i = 0; i < 4; ++i)
    if (got.aux[i] != want.aux[i]) return {step, "world", aux[i]};
  return {step, "world", "state"};
}

json to_json(const std::optional<Divergence>& d) {
  if (!d) return nullptr;
  return {{"step", d->step}, {"body", d->body}, {"quantity", d->quantity}};
}

Recording read_recording(const std::filesystem::path& evidence) {
  if (!std::filesystem::exists(evidence)) bad(evidence, "no such file");
  std::vector<json> records;
  try {
    records = read_evidence(evidence);
  } catch (const std::runtime_error& e) {
    throw EvidenceError(e.what());
  }
  Recording r;
  r.evidence = evidence;
  bool request = false, start = false;
  std::map<std::string, RecordedCommand> grounded;
  std::map<std::string, std::size_t> dispatched;  // command id -> index in r.commands
  try {
    for (const auto& e : records) {
      const std::string kind = e.value("kind", "");
      if (kind == "episode_request") {
        request = true;
        r.suite = e.at("suite").get<std::string>();
        r.task = e.at("task").get<unsigned>();
        r.seed = e.at("seed").get<std::uint64_t>();
        r.arm = e.value("arm", "full");
        r.robot = e.value("robot", "");
        r.build = e.value("build", "");
      } else if (kind == "episode_start") {
        start = true;
        r.episode_id = e.at("episode_id").get<std::string>();
        r.budget_steps = e.at("budget_steps").get<std::uint32_t>();
        r.instruction = e.value("instruction", "");
        r.decision_period = e.value("decision_period", 10u);
        if (e.value("grounding", "state") == "perception") r.perception = limits_from(e.at("perception"));
      } else if (kind == "scene_estimate") {
        r.estimates.push_back(estimate_from(e.at("estimate")));
      } else if (kind == "grounding" && e.value("result", "") == "grounded") {
        RecordedCommand& c = grounded[e.at("command_id").get<std::string>()];
        c.id = e.at("command_id").get<std::string>();
        c.capability = e.at("capability").get<std::string>();
        c.version = e.value("version", "");
        c.args = e.value("args", json::object());
        c.theta = e.value("theta", json::object());
      } else if (kind == "dispatch") {
        const auto id = e.at("command_id").get<std::string>();
        if (!grounded.count(id))
          bad(evidence, "command " + id + " was dispatched without a grounding record");
        RecordedCommand c = grounded.at(id);
        c.start_step = e.at("step").get<std::uint32_t>();
        c.budget_steps = e.at("budget_steps").get<std::uint32_t>();
        dispatched[id] = r.commands.size();
        r.commands.push_back(std::move(c));
      } else if (kind == "budget_raised") {
        const auto it = dispatched.find(e.at("command_id").get<std::string>());
        if (it == dispatched.end())
          bad(evidence, "the budget of command " + e.at("command_id").get<std::string>() +
                            " was raised, but the evidence never dispatched it");
        r.commands[it->second].budget_raises.emplace_back(e.at("step").get<std::uint32_t>(),
                                                          e.at("to").get<std::uint32_t>());
      } else if (kind == "snapshot" && e.value("at", "") != "episode_start") {
        const auto it = dispatched.find(e.at("at").get<std::string>());
        if (it != dispatched.end())
          r.commands[it->second].snapshot = gov::MachineSnapshot{e.at("machine"), e.at("waits")};
      } else if (kind == "command_status") {
        const auto it = dispatched.find(e.at("command_id").get<std::string>());
        std::optional<RecordedEnd> end = recorded_end(e);  // read for every status record, dispatched or not
        if (it != dispatched.end() && end) r.commands[it->second].end = std::move(end);
      } else if (kind == "resumed") {
        r.resumed = ResumedFrom{e.at("from").get<std::string>(), e.at("command").get<std::uint32_t>(),
                                e.at("command_id").get<std::string>(), e.at("step").get<std::uint32_t>()};
      } else if (kind == "episode_end") {
        r.end = RecordedEpisodeEnd{e.at("success").get<bool>(), e.at("outcome").get<std::string>(),
                                   e.at("step").get<std::uint32_t>()};
      } else if (kind == "verdict_event") {
        r.verdicts[e.at("step").get<std::uint32_t>()] = e.at("value").get<bool>();
        r.predicates.insert(e.value("predicate", ""));
      }
    }
  } catch (const json::exception& e) {
    bad(evidence, std::string("a record lacks a field a re-run needs: ") + e.what());
  } catch (const std::invalid_argument& e) {
    bad(evidence, e.what());
  }
  if (!request || !start)
    bad(evidence, "no episode_request or episode_start record (not a governor's evidence?)");
  return r;
}

std::optional<RecordedEnd> recorded_end(const json& status) {
  const std::string state = status.at("state").get<std::string>();
  if (state == "accepted" || state == "running") return std::nullopt;
  return RecordedEnd{state, status.value("failure", "none"), status.value("stage", ""),
                     status.at("step").get<std::uint32_t>(), status.value("steps_used", 0u)};
}

cap::Bindings bindings(const json& args) {
  cap::Bindings b;
  for (const auto& [k, v] : args.items()) b.emplace_back(k, v.is_string() ? v.get<std::string>() : v.dump());
  return b;
}

cap::Theta theta_of(const json& t) {
  cap::Theta th;
  for (const auto& [k, v] : t.items())
    if (v.is_number()) th[k] = v.get<double>();
  return th;
}

cap::CommandStart command_start(const Recording& rec, const RecordedCommand& c, std::uint32_t at,
                                const cap::Theta& theta, const std::string& host) {
  return cap::CommandStart{0,
                           rec.episode_id,
                           c.id,
                           c.capability,
                           c.capability + "@" + host,
                           bindings(c.args),
                           theta,
                           at,
                           c.budget_steps,
                           rec.decision_period,
                           rec.perception ? cap::Grounding::Perception : cap::Grounding::State,
                           rec.perception.value_or(PerceptionLimits{})};
}

void restore_host(cap::HostCore& host, sim::Workcell& cell, const Recording& rec, const sim::StateLog& states,
                  std::size_t k, const std::string& host_name) {
  for (std::size_t i = 0; i < k && i < rec.commands.size(); ++i) {
    const RecordedCommand& c = rec.commands[i];
    const sim::StateRecord* r = states.for_command(c.id);
    if (!r) continue;  // its lease never reached the seam: it never started
    cell.restore(r->state);
    Observation at = cell.observe();
    at.episode_id = rec.episode_id;
    at.step = r->step;
    at.budget_steps = rec.budget_steps;
    host.on_observation(at, step_time(r->step));
    host.on_start(command_start(rec, c, r->step, theta_of(c.theta), host_name), step_time(r->step));
    host.on_cancel({0, rec.episode_id, c.id, c.capability + "@" + host_name});
  }
}

}  // namespace dh::inproc
