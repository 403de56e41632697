#include "dh/inproc/replay.hpp"

#include <mujoco/mujoco.h>

#include <cstring>
#include <map>
#include <set>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/host_core.hpp"
#include "dh/cap/library.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/build_info.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/bus.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/state_log.hpp"
#include "dh/sim/step_log.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {
namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::filesystem::path& evidence, const std::string& what) {
  throw EvidenceError("evidence " + evidence.string() + ": " + what);
}

/// θ of each grounded capability against the library's descriptor; each difference named.
std::vector<std::string> theta_drift(const Recording& rec, const std::vector<cap::CapabilityDef>& defs,
                                     const std::filesystem::path& library) {
  std::vector<std::string> drift;
  std::map<std::string, bool> checked;
  for (const auto& c : rec.commands) {
    if (checked[c.capability]) continue;
    checked[c.capability] = true;
    const cap::CapabilityDef* def = cap::find_capability(defs, c.capability);
    if (!def) continue;  // reported as recorded-only
    const auto file = library / (c.capability + ".yaml");
    const cap::Theta now = cap::load_descriptor(file, *def).parameters;
    for (const auto& [k, v] : c.theta.items()) {
      const auto it = now.find(k);
      if (it == now.end())
        drift.push_back(c.capability + " θ " + k + " = " + v.dump() + " is recorded; " + file.string() + " has no " + k);
      else if (!v.is_number() || v.get<double>() != it->second)
        drift.push_back(c.capability + " θ " + k + " = " + v.dump() + " is recorded; " + file.string() + " has " +
                        json(it->second).dump());
    }
    for (const auto& [k, v] : now)
      if (!c.theta.contains(k))
        drift.push_back(c.capability + " θ " + k + " = " + json(v).dump() + " in " + file.string() + " is not recorded");
  }
  return drift;
}

}  // namespace

ReplayReport replay(const std::filesystem::path& evidence, const ReplayOptions& o) {
  const Recording rec = read_recording(evidence);
  if (rec.resumed)
    bad(evidence, "the rest of " + rec.resumed->evidence.string() + " from its command " +
                      std::to_string(rec.resumed->command) + " (step " + std::to_string(rec.resumed->step) +
                      "), run in process without a step log: replay " + rec.resumed->evidence.string() +
                      ", or probe its command again with `dh probe --rest`");
  const auto steps_file = std::filesystem::path(evidence).replace_extension(".steps");
  const sim::StepLog log = sim::read_step_log(steps_file);
  if (log.records.empty()) bad(steps_file, "the step log has no record of step 0");
  // The state log is needed to start from a command; a full replay compares it when it is there (a
  // recording copied without it, or older than it, replays from its step log alone).
  const auto states_file = std::filesystem::path(evidence).replace_extension(".states");
  sim::StateLog states;
  if (o.from_command || std::filesystem::exists(states_file)) {
    states = sim::read_state_log(states_file);
    if (states.header.model_hash != log.header.model_hash)
      bad(states_file, "the state log is of another model than the step log beside it");
  }
  if (o.from_command && *o.from_command >= rec.commands.size())
    throw std::invalid_argument("--from-command " + std::to_string(*o.from_command) + ": the episode dispatched " +
                                std::to_string(rec.commands.size()) + " command(s), numbered from 0");

  const auto suites = load_suites(o.config_dir);
  const TaskDef& task = find_task(suites, rec.suite, rec.task);
  sim::Workcell cell(sim::load_task_scene(task, rec.seed, rec.robot));
  const std::vector<cap::CapabilityDef> defs = cap::all_capabilities();
  const auto arms = load_arms(o.config_dir / "governor.yaml");
  // A skill grounded in perception runs again on the estimates the governor recorded, each given to the
  // host before the step whose action had taken it in (the step log's frames). From a command's start the
  // host's perceived world is not re-made, and evidence older than recorded estimates has none.
  const bool perception = find_arm(arms, rec.arm).grounding == "perception";
  const bool remade = perception && rec.perception && !o.from_command;

  ReplayReport report;
  report.episode_id = rec.episode_id;
  report.recorded_steps = static_cast<std::uint32_t>(log.records.size() - 1);
  report.commands = static_cast<std::uint32_t>(rec.commands.size());
  if (cell.model_hash() != log.header.model_hash)
    report.drift.push_back("the model of " + task.scene_file.filename().string() + " compiles to another hash than the recorded one (scene, "
                           "assets or robot changed)");
  if (static_cast<std::uint32_t>(mj_version()) != log.header.mujoco_version)
    report.drift.push_back("MuJoCo " + std::to_string(mj_version()) + " replays a recording of MuJoCo " +
                           std::to_string(log.header.mujoco_version));
  if (rec.build != build_info().str())
    report.drift.push_back("recorded by build " + (rec.build.empty() ? std::string("(none recorded)") : rec.build) +
                           "; this is build " + build_info().str());
  // The simulator may have run another build than the governor (another host).
  if (log.header.build != build_info().str() && log.header.build != rec.build)
    report.drift.push_back("simulated by build " + (log.header.build.empty() ? std::string("(none recorded)") : log.header.build) +
                           "; this is build " + build_info().str());
  // The suite's task as recorded: the instruction and budget the governor had, the goal the seam checked.
  if (rec.instruction != task.instruction)
    report.drift.push_back(rec.suite + " task " + std::to_string(rec.task) + " says \"" + task.instruction +
                           "\"; the recording's instruction was \"" + rec.instruction + "\"");
  if (rec.budget_steps != task.budget_steps)
    report.drift.push_back(rec.suite + " task " + std::to_string(rec.task) + " has a budget of " +
                           std::to_string(task.budget_steps) + " steps; the recording had " +
                           std::to_string(rec.budget_steps));
  for (const auto& p : rec.predicates)
    if (p != goal_text(task.goal))
      report.drift.push_back(rec.suite + " task " + std::to_string(rec.task) + "'s goal is " + goal_text(task.goal) +
                             "; the recording checked " + p);
  const auto library = o.library_dir.empty() ? o.config_dir / "library" : o.library_dir;
  for (auto& d : theta_drift(rec, defs, library)) report.drift.push_back(std::move(d));
  if (!report.drift.empty() && !o.allow_drift) {
    std::string what = "the replay would not run what was recorded (--allow-drift runs it anyway):";
    for (const auto& d : report.drift) what += "\n  " + d;
    throw FingerprintMismatch(what);
  }

  // Which commands the skills give again here, and which only the record has.
  std::map<std::string, const RecordedCommand*> by_id;
  std::vector<cap::ServedCapability> served;
  for (const auto& c : rec.commands) {
    by_id[c.id] = &c;
    if (perception && !remade)
      report.recorded_only.push_back(
          c.capability +
          (o.from_command
               ? " (grounded in perception: from a command's start its perceived world is not re-made)"
               : " (grounded in perception, in evidence that did not record the estimates)"));
    else if (!cap::find_capability(defs, c.capability))
      report.recorded_only.push_back(c.capability + " " + c.version + " (not an analytic or recovery skill of this build)");
  }
  for (const auto& d : defs) served.push_back({d, d.name + "@replay"});
  cap::HostCore host(served);
  const auto rerun = [&](const RecordedCommand& c) {
    return (!perception || remade) && cap::find_capability(defs, c.capability);
  };

  // With --from-command K: the seam resumes from the state recorded at K's start, and the last step to
  // replay is the last one K's actions led to.
  const sim::StateRecord* resume_from = nullptr;
  std::uint32_t last = report.recorded_steps;
  std::string only;
  std::size_t next = 0;  // the next recorded command to give the host
  if (o.from_command) {
    const RecordedCommand& k = rec.commands[*o.from_command];
    only = k.id;
    next = *o.from_command;
    resume_from = states.for_command(k.id);
    if (!resume_from)
      bad(states_file, "no state recorded at the start of command " + std::to_string(*o.from_command) + " (" + k.id +
                           "): its lease never reached the seam");
    if (resume_from->step >= log.records.size())
      bad(states_file, "command " + k.id + " starts at step " + std::to_string(resume_from->step) +
                           ", after the step log's last record");
    report.from_step = resume_from->step;
    last = resume_from->step;  // the command sent no action (refused, or ended at once)
    for (std::size_t i = 1; i < log.records.size(); ++i)
      if (log.records[i].command_id == k.id) last = static_cast<std::uint32_t>(i);
  }

  cell.reset(rec.seed, task.goal);
  // The capability host's state at K's start: the keyframes the commands before K left.
  if (resume_from) restore_host(host, cell, rec, states, *o.from_command, "replay");
  sim::SeamCore seam(0, kBusSeam);
  const std::string predicate = goal_text(task.goal);
  const std::uint32_t first = resume_from ? resume_from->step : 0;
  Observation obs =
      *(resume_from ? seam.resume(cell, rec.episode_id, rec.budget_steps, predicate, *resume_from, step_time(first))
                    : seam.start(cell, rec.episode_id, rec.budget_steps, predicate, step_time(0)))
           .observation;
  const auto note = [&](const Divergence& d) {
    ++report.divergent_steps;
    if (!report.first_divergence) report.first_divergence = d;
  };
  // Every step's digest is compared, and every recorded state on the way whole (the states a probe would
  // start from; a resumed one is the record itself, its digest is what says it was restored exactly).
  const auto check_states = [&](std::uint32_t step, bool whole) {
    if (cell.digest() != log.records[step].digest)
      note(divergence_at(cell, step, log.records[step].digest));
    for (const auto& r : states.records)
      if (whole && r.step == step) {
        ++report.states_checked;
        if (!(cell.physics_state() == r.state)) note({step, "world", "recorded state of command '" + r.command_id + "'"});
      }
  };
  check_states(first, !resume_from);
  if (o.on_step) o.on_step(first, cell);

  std::map<std::uint32_t, bool> verdicts;
  std::optional<cap::ActionOut> action;  // the skills' answer to the current step
  const auto take = [&](const cap::HostEffects& fx) {
    for (const auto& a : fx.actions) action = a;
  };
  // The recorded estimates the re-run skill of the action after step `i` had taken in, given before it.
  std::size_t fed = 0;
  const auto perceive = [&](std::uint32_t i) {
    if (!remade || i + 1 >= log.records.size()) return;
    const sim::StepRecord& next_action = log.records[i + 1];
    const auto c = by_id.find(next_action.command_id);
    if (c == by_id.end() || !rerun(*c->second)) return;
    for (; fed < next_action.frames && fed < rec.estimates.size(); ++fed)
      take(host.on_scene_estimate(0, rec.estimates[fed], step_time(i)));
  };
  perceive(first);
  take(host.on_observation(obs, step_time(first)));
  for (std::uint32_t i = first + 1; i <= last; ++i) {
    const sim::StepRecord& r = log.records[i];
    const std::uint32_t t = i - 1;  // the step the action answers
    if (r.step != i) bad(steps_file, "record " + std::to_string(i) + " is for step " + std::to_string(r.step));
    for (; next < rec.commands.size() && rec.commands[next].start_step <= t; ++next) {
      const RecordedCommand& c = rec.commands[next];
      if (!rerun(c)) continue;
      take(host.on_start(command_start(rec, c, c.start_step, theta_of(c.theta), "replay"), step_time(t)));
    }
    const auto cmd = by_id.find(r.command_id);
    if (cmd == by_id.end())
      bad(evidence, "step " + std::to_string(i) + " was reached by an action of command '" + r.command_id +
                        "', which the evidence never dispatched");
    if (rerun(*cmd->second) && (only.empty() || r.command_id == only)) {
      ++report.actions_compared;
      if (!action || action->command_id != r.command_id || action->step != t) {
        note({t, cmd->second->capability, "action (the skill gave none)"});
      } else {
        for (int k = 0; k < 7; ++k)
          if (std::memcmp(&action->a[k], &r.action[k], sizeof(double)) != 0) {
            note({t, cmd->second->capability, "action[" + std::to_string(k) + "]"});
            break;
          }
      }
    }
    action.reset();
    seam.on_lease({rec.episode_id, r.command_id, i, i, false}, step_time(t));
    const sim::SeamEffects sx = seam.on_action({rec.episode_id, r.command_id, t, r.action}, step_time(t));
    if (sx.ended) bad(evidence, "the replay could not step: " + *sx.ended);
    if (!sx.observation)
      bad(evidence, "the seam refused the recorded action of step " + std::to_string(t) + ": " +
                        (sx.events.empty() ? std::string("held") : sx.events.front().reason));
    if (sx.verdict) verdicts[sx.verdict->step] = sx.verdict->value;
    obs = *sx.observation;
    report.steps = i;
    check_states(i, true);
    if (o.on_step) o.on_step(i, cell);
    // The raises the governor made on the statuses of the steps so far reached the host before this step
    // (a lease only ever raises a budget, so one given again changes nothing).
    for (const RecordedCommand& c : rec.commands)
      for (const auto& [at, budget] : c.budget_raises)
        if (at < i) host.on_lease(0, rec.episode_id, c.id, c.start_step + budget);
    perceive(i);
    take(host.on_observation(obs, step_time(i)));
  }
  if (!o.from_command) report.verdicts_identical = verdicts == rec.verdicts;
  report.identical = !report.first_divergence && report.verdicts_identical;
  return report;
}

nlohmann::json to_json(const ReplayReport& r) {
  json j{{"episode_id", r.episode_id},
         {"identical", r.identical},
         {"steps", r.steps},
         {"recorded_steps", r.recorded_steps},
         {"commands", r.commands},
         {"from_step", r.from_step},
         {"states_checked", r.states_checked},
         {"divergent_steps", r.divergent_steps},
         {"actions_compared", r.actions_compared},
         {"recorded_only", r.recorded_only},
         {"drift", r.drift},
         {"verdicts_identical", r.verdicts_identical},
         {"first_divergence", to_json(r.first_divergence)}};
  return j;
}

}  // namespace dh::inproc
