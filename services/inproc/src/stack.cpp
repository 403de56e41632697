#include "dh/inproc/stack.hpp"

#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>

#include "dh/cap/library.hpp"
#include "dh/common/config.hpp"
#include "dh/common/evidence.hpp"
#include "dh/gov/config.hpp"
#include "dh/inproc/bus.hpp"
#include "dh/sim/predicates.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/state_log.hpp"

namespace dh::inproc {
namespace {

/// A resumed episode's evidence opens with the recorded episode's request and start and says where it was
/// taken up, so it reads as an episode of its own (attribution, the view) and points a replay at the
/// recording, which holds the steps before it.
void write_resumed_heading(const Recording& rec, std::uint32_t command, std::uint32_t step,
                           const std::filesystem::path& evidence_path) {
  std::error_code same;
  if (std::filesystem::equivalent(rec.evidence, evidence_path, same))
    throw std::invalid_argument(
        evidence_path.string() +
        " is the recording itself: the resumed episode's evidence goes to another file");
  std::filesystem::remove(evidence_path);
  {
    std::ofstream out(evidence_path);
    for (const auto& e : read_evidence(rec.evidence)) {
      const std::string kind = e.value("kind", "");
      if (kind == "episode_request" || kind == "episode_start") out << e.dump() << '\n';
    }
    if (!out) throw std::runtime_error(evidence_path.string() + ": cannot be written");
  }
  EvidenceWriter(evidence_path)
      .append("inproc", "resumed",
              {{"from", std::filesystem::absolute(rec.evidence).string()},
               {"command", command},
               {"command_id", rec.commands[command].id},
               {"step", step}});
}

}  // namespace

Stack::Stack(const std::filesystem::path& config_dir, const std::filesystem::path& library_dir)
    : config_dir_(config_dir),
      config_(gov::load_config(config_dir / "governor.yaml")),
      arms_(load_arms(config_dir / "governor.yaml")),
      governor_(config_, arms_,
                // Every capability is served before the first request: nothing to wait for.
                {{}, gov::Clock::time_point{}, std::nullopt}),
      host_({}),
      library_(cap::load_library_theta(library_dir.empty() ? config_dir / "library" : library_dir)) {
  const auto dir = library_dir.empty() ? config_dir / "library" : library_dir;
  for (auto& def : cap::all_capabilities()) add_capability(std::move(def), dir);
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
  governor_.on_announce(info);
  served_.push_back({def, info.instance});
  host_.serve({std::move(def), info.instance});
}

sim::Workcell& Stack::cell_for(const TaskDef& task, std::uint64_t seed, const std::string& robot,
                               bool perceives) {
  if (!perceives) return cells_.get(task, seed, robot).cell;
  if (!perception_) {
    perception_ = std::make_unique<BusPerception>(config_dir_);
    seen_cells_ =
        std::make_unique<sim::WorkcellCache>([p = perception_.get()](sim::SceneSpec& s) { p->dress(s); });
  }
  return seen_cells_->get(task, seed, robot).cell;
}

EpisodeOutcome Stack::run(const TaskDef& task, std::uint64_t seed, const std::string& arm,
                          const std::filesystem::path& evidence_path, const StepTap& tap) {
  // The arm's settings travel in the request, as `dh campaign` sends them.
  const gov::GovernorConfig settings = gov::for_arm(config_, find_arm(arms_, arm));
  const bool perceives = settings.perception.has_value();
  sim::Workcell& cell = cell_for(task, seed, robot_, perceives);
  cell.reset(seed, task.goal);
  std::filesystem::remove(evidence_path);
  // Unique per run: the host core keeps a channel's keyframes for as long as its episode id stays the same.
  const std::string episode_id =
      task.suite + "/" + std::to_string(task.id) + "/" + std::to_string(seed) + "#" + std::to_string(++runs_);
  gov::EpisodeRequest request;
  request.channel = kChannel;
  request.episode_id = episode_id;
  request.instruction = task.instruction;
  request.arm = arm;
  request.suite = task.suite;
  request.cell = task.suite;  // the cell is the suite here
  request.robot = robot_;
  request.task = task.id;
  request.seed = seed;
  request.budget_steps = task.budget_steps;
  request.library_version = library_.version;
  request.library = library_.theta;
  request.library_costs = library_.cost_steps;
  request.evidence = evidence_path;
  request.planner_errors = planner_errors_;
  request.goal = sim::goal_terms(cell.scene(), task.goal);  // as `dh campaign` resolves it
  request.decision_period = settings.decision_period;
  request.grounding = perceives ? "perception" : "state";
  request.perception = settings.perception_limits;
  sim::SeamCore seam(kChannel, kBusSeam);
  const cap::Clock::time_point now = step_time(0);
  const Observation obs = *seam.start(cell, episode_id, task.budget_steps, goal_text(task.goal), now,
                                      std::filesystem::path(evidence_path).replace_extension(".steps"))
                               .observation;
  if (perceives) perception_->begin(episode_id, task, cell, now);
  return drive(
      {cell, seam, obs, now, episode_id, evidence_path, tap, false, perceives ? perception_.get() : nullptr},
      [&] {
        auto fx = governor_.on_request(request, now);
        // In process nothing else can be the cause: a refused request (an unknown arm, say) is the caller's
        // configuration error, not an episode's outcome.
        for (const auto& e : fx)
          if (e.fx.end && e.fx.end->outcome == Outcome::Rejected)
            throw ConfigError("episode " + episode_id + ": " + e.fx.end->reason);
        return fx;
      });
}

EpisodeOutcome Stack::resume(const Resume& r, const std::filesystem::path& evidence_path,
                             const StepTap& tap) {
  const Recording& rec = r.recording;
  if (r.command >= rec.commands.size())
    throw std::invalid_argument("command " + std::to_string(r.command) + ": the episode dispatched " +
                                std::to_string(rec.commands.size()) + " command(s), numbered from 0");
  const RecordedCommand& k = rec.commands[r.command];
  if (!k.snapshot)
    throw EvidenceError(rec.evidence.string() + ": no snapshot of the governor at the dispatch of " + k.id +
                        " (evidence written before snapshots were recorded)");
  const sim::StateRecord* from = r.states.for_command(k.id);
  if (!from)
    throw EvidenceError(rec.evidence.string() + ": no state recorded at the start of command " + k.id +
                        " (its lease never reached the seam, so it never ran)");
  const gov::EpisodeSpec recorded = gov::snapshot_spec(*k.snapshot);
  const bool perceives = recorded.grounding == "perception";
  sim::Workcell& cell = cell_for(r.task, rec.seed, rec.robot, perceives);
  cell.reset(rec.seed, r.task.goal);
  host_ = cap::HostCore(served_);  // the earlier commands' keyframes only, not those of a run before
  restore_host(host_, cell, rec, r.states, r.command, "inproc");
  if (perceives) {
    if (!recorded.perception || !k.snapshot->state.contains("perceived_world"))
      throw EvidenceError(rec.evidence.string() + ": the snapshot at the dispatch of " + k.id +
                          " grounds in perception but holds no perceived world (evidence of an older build)");
    // The host takes in the estimates and observations the governor does: the snapshot's world is its too.
    host_.restore_world(
        kChannel, PerceivedWorld::from_state(k.snapshot->state.at("perceived_world"), *recorded.perception));
  }
  sim::SeamCore seam(kChannel, kBusSeam);
  const cap::Clock::time_point now = step_time(from->step);
  const Observation obs =
      *seam.resume(cell, rec.episode_id, rec.budget_steps, goal_text(r.task.goal), *from, now).observation;
  // Perception looks afresh from the resumed step: its own schedule of looks is not in the evidence.
  if (perceives) perception_->begin(rec.episode_id, r.task, cell, now);
  const std::string version = r.library ? r.library->version : recorded.library_version;
  const auto& library = r.library ? r.library->theta : recorded.library;
  const auto& costs = r.library ? r.library->cost_steps : recorded.library_costs;
  write_resumed_heading(rec, r.command, from->step, evidence_path);
  return drive({cell, seam, obs, now, rec.episode_id, evidence_path, tap, true,
                perceives ? perception_.get() : nullptr},
               [&] {
                 return governor_.resume(kChannel, *k.snapshot, evidence_path, version, library, costs,
                                         r.budget_steps, now);
               });
}

EpisodeOutcome Stack::drive(Episode ep, const std::function<gov::CoreEffects()>& first) {
  sim::SeamCore& seam = ep.seam;
  Observation obs = ep.obs;
  cap::Clock::time_point now = ep.now;
  const std::string& episode_id = ep.episode_id;
  const StepTap& tap = ep.tap;
  std::optional<gov::EpisodeEnd> end;
  std::optional<cap::ActionOut> action;            ///< the host's answer to the current step
  std::map<std::string, gov::Command> dispatched;  ///< by command id

  bool fresh = !ep.governor_saw_obs;  // the seam stepped: its observation is new to every core
  std::function<void(cap::HostEffects)> from_host;
  std::function<void(gov::CoreEffects)> from_governor;
  // The seam's effects: its refusals, corrections, end and verdict changes go to the governor (over DDS they
  // are the seam and verdict topics); a new step is seen next round.
  const auto deliver = [&](const sim::SeamEffects& sx) {
    for (const auto& e : sx.events) from_governor(governor_.on_seam_event(kChannel, episode_id, e, now));
    if (sx.verdict)
      governor_.on_verdict(kChannel, episode_id, sx.verdict->step, sx.verdict->predicate, sx.verdict->value);
    if (sx.ended) {
      if (!end)
        throw std::logic_error("episode " + episode_id + " goes on after its seam ended it: " + *sx.ended);
      return;
    }
    if (!sx.observation) return;
    obs = *sx.observation;
    now += std::chrono::milliseconds(50);
    fresh = true;
  };
  // Routes the governor's effects the way the DDS shells carry them, at once (one control step).
  from_governor = [&](gov::CoreEffects effects) {
    for (const gov::ChannelEffects& e : effects) {
      if (e.episode_id != episode_id) continue;
      const gov::Effects& fx = e.fx;
      if (fx.cancel_command)
        from_host(host_.on_cancel({kChannel, episode_id, *fx.cancel_command, e.cancel_instance}));
      if (fx.lease) {
        host_.on_lease(kChannel, episode_id, fx.lease->command_id, fx.lease->budget_until_step);
        deliver(seam.on_lease({episode_id, fx.lease->command_id, fx.lease->valid_until_step,
                               fx.lease->budget_until_step, fx.lease->revoked},
                              now));
      }
      if (fx.end) end = fx.end;
      if (fx.command) {
        const gov::Command& g = *fx.command;
        dispatched[g.command_id] = g;
        cap::CommandStart c{kChannel,
                            episode_id,
                            g.command_id,
                            g.capability,
                            g.instance,
                            g.args,
                            g.theta,
                            g.start_step,
                            g.budget_steps,
                            g.decision_period,
                            g.perception ? cap::Grounding::Perception : cap::Grounding::State,
                            g.perception.value_or(PerceptionLimits{})};
        from_host(host_.on_start(c, now));
      }
      if (fx.plan_request) {
        const auto& r = *fx.plan_request;
        const auto answer = std::get<planner::Answer>(
            planner_.on_request({kChannel,
                                 r.request_id,
                                 episode_id,
                                 {r.instruction, r.scene, r.capabilities, r.history},
                                 r.seed,
                                 r.index,
                                 r.errors}));
        const planner::PlannerAdvice& a = answer.advice;
        gov::Advice adv{r.request_id, a.refused, a.capability, a.args, a.rationale,
                        a.reason,     "rules",   a.done,       {},     answer.injected};
        for (const auto& s : a.rest) adv.rest.push_back({s.capability, s.args});
        adv.why = a.why;
        from_governor(governor_.on_advice(kChannel, episode_id, adv, now));
      }
    }
  };
  // The perception service's estimates go to the governor and to the host, as the scene topic carries them.
  const auto perceived = [&](const std::vector<SceneEstimate>& estimates) {
    for (const auto& e : estimates) {
      from_governor(governor_.on_scene_estimate(kChannel, e, now));
      from_host(host_.on_scene_estimate(kChannel, e, now));
    }
  };
  from_host = [&](cap::HostEffects hx) {
    for (const auto& s : hx.statuses)
      if (s.episode_id == episode_id)  // not a command left over from an earlier episode
        from_governor(governor_.on_status(kChannel, episode_id,
                                          {s.command_id, s.instance, s.state, s.reason, s.stage, s.step,
                                           s.steps_used, s.progress, s.failure, s.planned_steps},
                                          now));
    for (const auto& a : hx.actions) action = a;
  };

  // Over DDS every host has the first observation before the first command starts (the planner answers
  // after it), so that command's start records the episode's first keyframe: the same order here.
  from_host(host_.on_observation(obs, now));
  std::uint32_t host_step = obs.step;  ///< the last step the host saw
  try {
    from_governor(first());
    while (!end) {
      if (fresh) {
        fresh = false;
        from_governor(governor_.on_observation(obs, now));
        if (obs.step != host_step) {
          host_step = obs.step;
          action.reset();
          from_host(host_.on_observation(obs, now));
        }
        // Perception sees the step after the others did: over DDS its frame comes after the observation.
        if (ep.perception) perceived(ep.perception->on_observation(obs, now));
      }
      // Nothing moves this step: wait, as a stalled channel would, for the governor's next deadline (a
      // deadline acts by ending the episode or by changing what runs, so a few waits settle it). A robot
      // standing still is looked at again meanwhile, as the perception service does.
      for (int deadlines = 0; !end && !(action && action->step == obs.step);) {
        const auto deadline = governor_.deadline(kChannel);
        if (deadlines == 4 || !deadline)
          throw std::logic_error("episode " + episode_id + " stands still at step " +
                                 std::to_string(obs.step) +
                                 ": no action and no end after the governor's deadlines");
        if (ep.perception && *deadline > now + ep.perception->still_every()) {
          now += ep.perception->still_every();
        } else {
          now = std::max(now, *deadline);
          ++deadlines;
        }
        if (ep.perception) perceived(ep.perception->on_tick(now, obs.step));
        if (end || (action && action->step == obs.step)) break;
        from_host(host_.on_tick(now));
        from_governor(governor_.on_tick(now));
        deliver(seam.on_tick(now));
      }
      if (end || fresh) continue;
      if (tap.on_action) tap.on_action(obs, dispatched[action->command_id].capability, action->a);
      sim::ActionIn applied{action->episode_id, action->command_id, action->step, action->a, action->frames};
      if (tap.perturb) tap.perturb(applied.a);
      action.reset();
      deliver(seam.on_action(applied, now));
      if (fresh && tap.on_step) tap.on_step(obs.step, ep.cell);
    }
  } catch (...) {
    governor_.forget(kChannel);
    throw;
  }
  return {end->success, end->outcome, end->reason, end->steps, end->decisions, end->refusals, ep.evidence};
}

}  // namespace dh::inproc
