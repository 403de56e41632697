#include "dh/inproc/stack.hpp"

#include <stdexcept>

#include "dh/cap/library.hpp"
#include "dh/gov/config.hpp"
#include "dh/planner/rules.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/seam.hpp"

namespace dh::inproc {

Stack::Stack(const std::filesystem::path& config_dir)
    : config_(gov::load_config(config_dir / "governor.yaml")), arms_(load_arms(config_dir / "governor.yaml")) {
  for (auto& def : cap::all_capabilities()) add_capability(std::move(def), config_dir / "library");
}

void Stack::add_capability(cap::CapabilityDef def, const std::filesystem::path& library_dir) {
  const cap::Descriptor d = cap::load_descriptor(library_dir / (def.name + ".yaml"), def);
  gov::CapabilityInfo info;
  info.capability = d.capability;
  info.instance = d.capability + "@inproc";
  info.version = d.version;
  info.arguments = d.arguments;
  info.preconditions = d.preconditions;
  info.parameters = d.parameters;
  info.cost_steps = static_cast<std::uint32_t>(d.cost_steps);
  info.started_ns = 1;
  registry_.announce(info);
  defs_.insert_or_assign(def.name, std::move(def));
}

void Stack::set_parameters(const std::string& capability, const cap::Theta& theta) {
  auto info = registry_.newest_alive(capability);
  if (!info) throw std::invalid_argument("no capability '" + capability + "'");
  for (const auto& [k, v] : theta) info->parameters[k] = v;
  info->cost_steps = static_cast<std::uint32_t>(defs_.at(capability).make(info->parameters)->cost_steps());
  registry_.announce(*info);
}

sim::Workcell& Stack::cell_for(const TaskDef& task) {
  auto& c = cells_[sim::task_scene_key(task)];
  if (!c) c = std::make_unique<sim::Workcell>(sim::load_task_scene(task));
  return *c;
}

EpisodeOutcome Stack::run(const TaskDef& task, std::uint64_t seed, const std::string& arm,
                          const std::filesystem::path& evidence_path, const StepTap& tap) {
  sim::Workcell& cell = cell_for(task);
  cell.reset(seed, task.goal);
  std::filesystem::remove(evidence_path);
  EvidenceWriter evidence(evidence_path);
  gov::EpisodeSpec spec{0, task.suite + "/" + std::to_string(task.id) + "/" + std::to_string(seed), task.instruction,
                        arm, task.budget_steps};
  gov::EpisodeMachine machine(spec, gov::for_arm(config_, find_arm(arms_, arm)), registry_, evidence,
                              gov::Clock::now());

  std::uint32_t step = 0;
  auto observe = [&] {
    Observation o = cell.observe();
    o.step = step;
    o.budget_steps = task.budget_steps;
    return o;
  };
  Observation obs = observe();

  struct Running {
    gov::Command command;
    std::unique_ptr<cap::Skill> skill;
    std::uint32_t used = 0;
  };
  std::optional<Running> running;
  std::vector<cap::Keyframe> keyframes;
  sim::LeaseState lease;
  std::optional<gov::EpisodeEnd> end;

  // Routes the machine's effects the way the node publishes them; plans and refusals at the capability
  // come back at once, as they would within the same control step over DDS.
  std::function<void(gov::Effects)> apply = [&](gov::Effects fx) {
    if (fx.cancel_command && running && running->command.command_id == *fx.cancel_command) running.reset();
    if (fx.lease) {
      lease = {true, fx.lease->command_id, fx.lease->valid_until_step, fx.lease->budget_until_step, fx.lease->revoked, false};
    }
    if (fx.end) end = fx.end;
    if (fx.command) {
      const gov::Command& c = *fx.command;
      if (!obs.holding())
        keyframes.push_back({obs.step, obs.ee_p, obs.ee_q});
      gov::CommandStatus st{c.command_id, c.instance, gov::CommandState::Accepted, "", "", obs.step, 0, 0};
      std::unique_ptr<cap::Skill> skill;
      try {
        skill = defs_.at(c.capability).make(c.theta);
        if (auto why = skill->check(c.args, obs, static_cast<int>(c.budget_steps))) {
          st.state = gov::CommandState::Refused;
          st.reason = *why;
        }
      } catch (const std::invalid_argument& e) {
        st.state = gov::CommandState::Refused;
        st.reason = std::string("malformed command: ") + e.what();
      }
      if (st.state == gov::CommandState::Accepted) {
        skill->start(c.args, obs, cap::SkillContext{keyframes});
        running = Running{c, std::move(skill), 0};
      }
      apply(machine.on_status(st, gov::Clock::now()));
    }
    if (fx.plan_request) {
      const auto& r = *fx.plan_request;
      const planner::PlannerAdvice a = planner::plan_rules({r.instruction, r.scene, r.capabilities, r.history});
      gov::Advice adv{r.request_id, a.refused, a.capability, a.args, a.rationale, a.reason, "rules", a.done, {}};
      for (const auto& s : a.rest) adv.rest.push_back({s.capability, s.args});
      apply(machine.on_advice(adv, gov::Clock::now()));
    }
  };

  apply(machine.on_observation(obs, gov::Clock::now()));
  while (!end) {
    if (!running) throw std::logic_error("episode machine waits with no command running at step " + std::to_string(step));
    const cap::SkillStep s = running->skill->next(obs);
    if (s.status != cap::SkillStatus::Running) {
      const bool ok = s.status == cap::SkillStatus::Completed;
      gov::CommandStatus st{running->command.command_id, running->command.instance,
                            ok ? gov::CommandState::Completed : gov::CommandState::Failed, s.reason, s.stage, obs.step,
                            running->used, s.progress};
      running.reset();
      apply(machine.on_status(st, gov::Clock::now()));
      continue;
    }
    const auto admitted = sim::admit_action(running->command.command_id, obs.step, step, task.budget_steps, lease, true);
    if (admitted.decision != sim::Admission::Apply) {
      gov::CommandStatus st{running->command.command_id, running->command.instance, gov::CommandState::Expired,
                            admitted.reason, s.stage, obs.step, running->used, s.progress};
      running.reset();
      apply(machine.on_status(st, gov::Clock::now()));
      continue;
    }
    if (tap.on_action) tap.on_action(obs, running->command.capability, s.action);
    std::array<double, 7> applied = s.action;
    if (tap.perturb) tap.perturb(applied);
    for (const auto& e : cell.step(applied))
      machine.on_seam_event(step, running->command.command_id,
                            e.kind == sim::StepEvent::SafetyHold ? "SEAM_SAFETY_HOLD" : "SEAM_ACTION_CLAMPED", e.reason);
    ++step;
    ++running->used;
    apply(machine.on_status({running->command.command_id, running->command.instance, gov::CommandState::Running, "",
                             s.stage, step, running->used, s.progress},
                            gov::Clock::now()));
    obs = observe();
    apply(machine.on_observation(obs, gov::Clock::now()));
  }
  return {end->success, end->outcome, end->reason, end->steps, end->decisions, end->refusals, evidence_path};
}

}  // namespace dh::inproc
