#include "dh/evo/probe.hpp"

#include <fmt/format.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <functional>
#include <map>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/library.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/suite.hpp"
#include "dh/evo/effect.hpp"
#include "dh/gov/grounding.hpp"
#include "dh/inproc/bus.hpp"
#include "dh/inproc/stack.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"

namespace dh::evo {
namespace {

using nlohmann::json;
constexpr const char* kHost = "probe";

/// Counts the cell's state at `step`, digested as `digest`, against the step log's; the first difference is
/// kept.
void compare_step(ProbeReport& r, const sim::Workcell& cell, const sim::StateDigest& digest,
                  std::uint32_t step, const sim::StepLog& log) {
  ++r.steps_compared;
  if (!r.first_divergence && digest != log.records[step].digest)
    r.first_divergence = inproc::divergence_at(cell, step, log.records[step].digest);
}

/// The probe's end is the recorded one: state, failure code, stage and step.
bool same_end(const inproc::RecordedCommand& k, const ProbeReport& r) {
  return k.end && k.end->state == r.state && k.end->failure == r.failure && k.end->stage == r.stage &&
         k.end->step == r.end_step;
}

/// The rest of the episode from command K on the in-process stack (ProbeOptions::rest): K's end and
/// effect, every step against the step log, and the episode's end beside the recorded one.
void rest_of_episode(ProbeReport& r, const inproc::Stack::Resume& from, const sim::StepLog& log,
                     const std::vector<PredicateSpec>& effect, const ProbeOptions& o) {
  const inproc::RecordedCommand& k = from.recording.commands[from.command];
  inproc::Stack stack(o.config_dir);
  std::map<std::uint32_t, bool> held;  ///< the effect's predicates after each step
  inproc::StepTap tap;
  tap.on_step = [&](std::uint32_t step, const sim::Workcell& cell) {
    if (!effect.empty()) held[step] = cell.holds(effect);
    const sim::StateDigest digest = cell.digest();
    r.end_digest = digest.state;
    if (step < log.records.size()) compare_step(r, cell, digest, step, log);
  };
  const bool temporary = o.rest_evidence.empty();
  const std::filesystem::path out =
      temporary ? std::filesystem::temp_directory_path() /
                      ("dh-probe-" + std::to_string(::getpid()) + "-" +
                       std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id())) + ".jsonl")
                : o.rest_evidence;
  const inproc::EpisodeOutcome end = stack.resume(from, out, tap);
  // K's end is its last status in the new evidence; a command the governor moved on from has none.
  r.state = to_string(CommandState::Cancelled);
  r.failure = to_string(FailureCode::None);
  r.end_step = end.steps;
  for (const auto& e : read_evidence(out)) {
    if (e.value("kind", "") != "command_status" || e.value("command_id", "") != k.id) continue;
    const std::optional<inproc::RecordedEnd> ended = inproc::recorded_end(e);
    if (!ended) continue;
    r.state = ended->state;
    r.failure = ended->failure;
    r.stage = ended->stage;
    r.end_step = ended->step;
    r.reason = e.value("reason", "");
  }
  if (temporary) std::filesystem::remove(out);
  if (effect.empty()) {
    r.effect_held = r.state == to_string(CommandState::Completed);
  } else {
    const auto at = held.upper_bound(r.end_step);  // the state after the end step's action, or before
    r.effect_held = at != held.begin() && std::prev(at)->second;
  }
  r.same_end = same_end(k, r);
  r.rest = RestReport{end.success, to_string(end.outcome), end.reason, end.steps, from.recording.end};
  const auto& rec_end = from.recording.end;
  r.reproduces = !r.first_divergence && (!k.end || r.same_end) && rec_end &&
                 rec_end->success == end.success && rec_end->outcome == to_string(end.outcome) &&
                 rec_end->steps == end.steps;
}

}  // namespace

ProbeReport probe(const std::filesystem::path& evidence, const ProbeOptions& o) {
  const inproc::Recording rec = inproc::read_recording(evidence);
  if (o.command >= rec.commands.size())
    throw std::invalid_argument("--command " + std::to_string(o.command) + ": the episode dispatched " +
                                std::to_string(rec.commands.size()) + " command(s), numbered from 0");
  const inproc::RecordedCommand& k = rec.commands[o.command];
  const auto arms = load_arms(o.config_dir / "governor.yaml");
  if (find_arm(arms, rec.arm).grounding == "perception" && !o.rest)
    throw std::invalid_argument(
        "command " + k.id +
        " was grounded in perception estimates, which a probe of the command alone does not "
        "re-make; --rest runs the rest of the episode with perception on the in-process bus");
  const std::vector<cap::CapabilityDef> defs = cap::all_capabilities();
  const cap::CapabilityDef* def = cap::find_capability(defs, k.capability);
  if (!def)
    throw std::invalid_argument(
        "command " + k.id + " ran " + k.capability + " " + k.version +
        ", not an analytic or recovery skill of this build: a probe cannot re-run it");

  const auto states_file = std::filesystem::path(evidence).replace_extension(".states");
  const auto steps_file = std::filesystem::path(evidence).replace_extension(".steps");
  sim::StateLog states;
  sim::StepLog log;
  try {
    states = sim::read_state_log(states_file);
    log = sim::read_step_log(steps_file);
  } catch (const std::runtime_error& e) {
    throw inproc::EvidenceError(e.what());
  }
  if (states.header.model_hash != log.header.model_hash)
    throw inproc::EvidenceError("state log " + states_file.string() +
                                " is of another model than the step log beside it");
  for (std::size_t i = 0; i < log.records.size(); ++i)
    if (log.records[i].step != i)
      throw inproc::EvidenceError("step log " + steps_file.string() + ": record " + std::to_string(i) +
                                  " is for step " + std::to_string(log.records[i].step));
  if (static_cast<std::uint32_t>(mj_version()) != log.header.mujoco_version)
    throw inproc::EvidenceError("step log " + steps_file.string() + " was recorded with MuJoCo " +
                                std::to_string(log.header.mujoco_version) + "; this build runs " +
                                std::to_string(mj_version()) + ", which does not step the same");
  const sim::StateRecord* from = states.for_command(k.id);
  if (!from)
    throw inproc::EvidenceError("state log " + states_file.string() +
                                ": no state recorded at the start of command " + k.id +
                                " (its lease never reached the seam, so it never ran)");

  const auto suites = load_suites(o.config_dir);
  const TaskDef& task = find_task(suites, rec.suite, rec.task);
  sim::Workcell cell(sim::load_task_scene(task, rec.seed, rec.robot));
  if (cell.model_hash() != states.header.model_hash)
    throw inproc::EvidenceError("state log " + states_file.string() + " is of another model than " +
                                task.scene_file.string() + " compiles to (scene, assets or robot changed)");
  cell.reset(rec.seed, task.goal);

  ProbeReport r;
  r.episode_id = rec.episode_id;
  r.command_id = k.id;
  r.capability = k.capability;
  r.from_step = from->step;
  r.recorded = k.end;
  cap::Theta theta = inproc::theta_of(k.theta);
  r.budget_steps = k.budget_steps;
  r.library = "recorded";
  std::optional<cap::Theta> candidate = o.theta;
  std::optional<cap::LibraryTheta> library;  ///< the candidate's, for the rest of the episode
  if (!o.library_dir.empty()) {
    library = cap::load_library_theta(o.library_dir);
    const auto t = library->theta.find(k.capability);
    if (t == library->theta.end())
      throw std::invalid_argument("library " + o.library_dir.string() + " has no " + k.capability + ".yaml");
    candidate = t->second;
    r.library = library->version;
  } else if (o.theta) {
    r.library = "theta " + cap::library_version({{k.capability, *o.theta}});
    if (o.rest) {
      if (!k.snapshot)
        throw inproc::EvidenceError(evidence.string() + ": no snapshot of the governor at the dispatch of " +
                                    k.id + " (evidence written before snapshots were recorded)");
      const gov::EpisodeSpec recorded = gov::snapshot_spec(*k.snapshot);
      library.emplace();
      library->theta = recorded.library;
      library->theta[k.capability] = *o.theta;
      library->cost_steps = recorded.library_costs;
      library->cost_steps[k.capability] = static_cast<std::uint32_t>(def->make(*o.theta)->cost_steps());
      library->version = cap::library_version(library->theta);
    }
  }
  const std::vector<PredicateSpec> effect = command_effect(inproc::bindings(k.args), task.goal);
  r.effect = effect.empty() ? "completion" : goal_text(effect);
  if (candidate) {
    theta = *candidate;
    // The budget the governor would give the candidate: its cost model, within what the episode had left;
    // a cost beyond that is refused at grounding, as the governor refuses it, and never runs.
    const auto cost = static_cast<std::uint32_t>(def->make(theta)->cost_steps());
    const std::uint32_t remaining = rec.budget_steps > from->step ? rec.budget_steps - from->step : 0;
    if (cost > remaining) {
      r.theta = json(theta);
      r.end_step = from->step;
      r.state = to_string(CommandState::Refused);
      r.failure = to_string(FailureCode::None);
      r.reason = "budget: " + std::to_string(remaining) + " steps remain, '" + k.capability +
                 "' under this θ costs " + std::to_string(cost);
      cell.restore(from->state);
      r.end_digest = cell.digest().state;
      r.effect_held = !effect.empty() && cell.holds(effect);
      // With the rest of the episode: not run, and not won (the governor would not dispatch K under it).
      if (o.rest) r.rest = RestReport{false, to_string(CommandState::Refused), r.reason, from->step, rec.end};
      return r;
    }
    r.budget_steps = gov::command_budget(cost, remaining);
  }
  r.theta = json(theta);

  if (o.rest) {
    rest_of_episode(r, {rec, states, task, o.command, library, r.budget_steps}, log, effect, o);
    return r;
  }

  std::vector<cap::ServedCapability> served;
  for (const auto& d : defs) served.push_back({d, d.name + "@" + kHost});
  cap::HostCore host(served);
  inproc::restore_host(host, cell, rec, states, o.command, kHost);

  inproc::CommandRunner runner(cell, host, rec.budget_steps);
  runner.resume_episode(rec.episode_id, goal_text(task.goal), *from);
  // Each step's physics against the step log, while the recording ran this command.
  runner.after_step = [&](std::uint32_t step) {
    if (step < log.records.size() && log.records[step].command_id == k.id)
      compare_step(r, cell, cell.digest(), step, log);
  };
  cap::CommandStart start = inproc::command_start(rec, k, from->step, theta, kHost);
  start.budget_steps = r.budget_steps;
  const inproc::CommandOutcome out = runner.run(std::move(start));

  r.end_step = out.last.step;
  r.end_digest = cell.digest().state;
  r.state = to_string(out.state);
  r.failure = to_string(out.failure);
  r.stage = out.stage;
  r.reason = out.reason;
  // The effect is the world's state at the command's end, however the command ended; a command whose
  // arguments name none is judged by its completion.
  r.effect_held = effect.empty() ? out.state == CommandState::Completed : cell.holds(effect);
  r.same_end = same_end(k, r);
  // Reproduced: every recorded step of the command the same, and its recorded end (if any) the same; a
  // command with neither recorded steps nor a recorded end has nothing to reproduce.
  r.reproduces = !r.first_divergence && (k.end ? r.same_end : r.steps_compared > 0);
  return r;
}

bool same_result(const ProbeReport& a, const ProbeReport& b) {
  const auto rest = [](const ProbeReport& r) {
    return r.rest ? std::tuple(true, r.rest->success, r.rest->outcome, r.rest->steps)
                  : std::tuple(false, false, std::string(), 0u);
  };
  return a.state == b.state && a.failure == b.failure && a.stage == b.stage && a.end_step == b.end_step &&
         a.effect_held == b.effect_held && a.end_digest == b.end_digest && rest(a) == rest(b);
}

json to_json(const ProbeReport& r) {
  json j{{"episode_id", r.episode_id},
         {"command_id", r.command_id},
         {"capability", r.capability},
         {"library", r.library},
         {"theta", r.theta},
         {"from_step", r.from_step},
         {"end_step", r.end_step},
         {"budget_steps", r.budget_steps},
         {"state", r.state},
         {"failure", r.failure},
         {"stage", r.stage},
         {"reason", r.reason},
         {"effect", r.effect},
         {"effect_held", r.effect_held},
         {"recorded", nullptr},
         {"same_end", r.same_end},
         {"steps_compared", r.steps_compared},
         {"first_divergence", inproc::to_json(r.first_divergence)},
         {"reproduces", r.reproduces},
         {"end_digest", fmt::format("{:016x}", r.end_digest)},
         {"rest", nullptr}};
  if (r.rest) {
    j["rest"] = {{"success", r.rest->success},
                 {"outcome", r.rest->outcome},
                 {"reason", r.rest->reason},
                 {"steps", r.rest->steps},
                 {"recorded", nullptr}};
    if (r.rest->recorded)
      j["rest"]["recorded"] = {{"success", r.rest->recorded->success},
                               {"outcome", r.rest->recorded->outcome},
                               {"steps", r.rest->recorded->steps}};
  }
  if (r.recorded)
    j["recorded"] = {{"state", r.recorded->state},
                     {"failure", r.recorded->failure},
                     {"stage", r.recorded->stage},
                     {"step", r.recorded->step}};
  return j;
}

}  // namespace dh::evo
