#include "dh/gov/episode.hpp"

#include <utility>

#include "dh/common/build_info.hpp"
#include "dh/common/history.hpp"
#include "dh/gov/config.hpp"

namespace dh::gov {

namespace {
nlohmann::json bindings_json(const Bindings& b) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [role, e] : b) j[role] = e;
  return j;
}
}  // namespace

EpisodeMachine::EpisodeMachine(EpisodeSpec spec, const GovernorConfig& config, const Registry& registry,
                               EvidenceWriter& evidence, Clock::time_point now)
    : spec_(std::move(spec)), config_(config), registry_(registry), evidence_(evidence) {
  if (config_.perception) world_.emplace(*config_.perception);
  if (world_ && !spec_.goal.empty()) perceived_.emplace(spec_.goal, config_.verdict_frames);
  nlohmann::json goal = nlohmann::json::array();
  for (const auto& t : spec_.goal) goal.push_back(t.text());
  deadline_ = now + config_.first_observation_timeout;
  deadline_what_ = "first observation from the simulator channel";
  deadline_wait_ = "first_observation";
  capability_wait_until_ = now + config_.ack_timeout;
  nlohmann::json start{{"episode_id", spec_.episode_id},
                       {"channel", spec_.channel},
                       {"instruction", spec_.instruction},
                       {"arm", spec_.arm},
                       {"budget_steps", spec_.budget_steps},
                       {"decision_period", config_.decision_period},
                       {"library_version", spec_.library_version},
                       {"verifier", to_string(config_.verifier)},
                       {"goal", goal},
                       {"grounding", config_.perception ? "perception" : "state"}};
  if (config_.perception) start["perception"] = limits_json(*config_.perception);
  evidence_.append("governor", "episode_start", std::move(start));
  // The governor waited for these (or its ready timeout passed): the episode runs without them.
  capabilities_missing_ = registry_.missing(needed_capabilities(config_, spec_));
  if (!capabilities_missing_.empty())
    evidence_.append("governor", "capabilities_missing", {{"step", 0}, {"missing", capabilities_missing_}});
}

nlohmann::json EpisodeMachine::obs_summary(const Observation& o) const {
  nlohmann::json entities = nlohmann::json::object();
  for (const auto& e : o.entities) entities[e.name] = {e.p[0], e.p[1], e.p[2]};
  return {{"step", o.step},
          {"ee", {o.ee_p[0], o.ee_p[1], o.ee_p[2]}},
          {"gripper_opening", o.gripper_opening},
          {"contacts", {o.contact_left, o.contact_right}},
          {"entities", entities},
          {"predicate", o.goal_holds}};
}

Effects EpisodeMachine::on_observation(Observation obs, Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (phase_ == Phase::Ended) return {};
  if (world_) world_->track(obs);
  if (config_.verifier == Verifier::Oracle) latch_.record(obs.step, obs.goal_holds);
  // Swapped, not copied: the previous observation's entities are freed with `obs`, after the decision.
  std::swap(last_obs_, obs);
  have_obs_ = true;
  take_progress(last_obs_.step, false);
  if (phase_ == Phase::WaitingFirstObservation) {
    evidence_.append("governor", "observation", obs_summary(last_obs_));
    if (config_.mode == ExecutorMode::Bare) {
      Advice a;
      a.capability = "vla_act";
      a.args = {{"instruction", spec_.instruction}};
      a.rationale = "bare arm: the policy owns the episode";
      a.backend = "none";
      set_step(a);
      return ground_and_dispatch(a, now);
    }
    return request_plan("episode start", now);
  }
  if (phase_ != Phase::Running) return {};
  std::optional<CommandStatus> ended;
  if (deferred_end_ && last_obs_.step >= deferred_end_->step) {
    ended = deferred_end_;
    deferred_end_.reset();
  }
  await_observation(now);
  Effects fx;
  if (last_obs_.step % config_.decision_period == 0 && last_obs_.step > running_->start_step)
    fx = decide_now(CommandPhase::Running, "decision step", now, {&last_obs_});
  // A command that ended at this step is finished after the step's decision, as in process, where its
  // report comes after the governor has seen the observation (over DDS it may come first and wait).
  if (!ended || phase_ != Phase::Running || !running_ || running_->command_id != ended->command_id) return fx;
  return then(fx, finish_command(*ended, now, false));
}

Observation EpisodeMachine::perceived_scene() {
  Observation seen = last_obs_;
  // The planner sees what perception saw; what it could not see is left out (the refusal comes at grounding).
  if (world_) world_->view(seen, {});
  return seen;
}

Effects EpisodeMachine::on_scene_estimate(const SceneEstimate& estimate, Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (!world_ || estimate.episode_id != spec_.episode_id || phase_ == Phase::Ended) return {};
  world_->on_estimate(estimate);
  // Every estimate, in the order taken in: dh replay gives a re-run skill's world the same ones.
  evidence_.append("governor", "scene_estimate",
                   {{"step", last_obs_.step}, {"estimate", estimate_json(estimate)}});
  // The verdict counts frames of the objects; a parts camera's frame only updates the parts it reads.
  if (perceived_ && have_obs_ && !estimate.looked_for.empty() && world_->latest() &&
      world_->latest()->step == estimate.step) {
    Observation seen = last_obs_;
    world_->view(seen, {});
    if (const auto change = perceived_->on_frame(estimate.step, seen)) {
      evidence_.append("governor", "perceived_verdict",
                       {{"step", change->step}, {"value", change->value}, {"frames", config_.verdict_frames},
                        {"oracle_at_observation", last_obs_.goal_holds}, {"observation_step", last_obs_.step}});
      if (config_.verifier == Verifier::Perception) latch_.record(change->step, change->value);
      if (phase_ == Phase::Verifying && change->value)
        return end(true, Outcome::Success, "planner: every step completed; the perceived verdict followed");
    }
    if (phase_ == Phase::Verifying && estimate.step >= verifying_from_ &&
        ++final_frames_ >= config_.verdict_wait_frames)
      return end(false, Outcome::GaveUp,
                 "planner: every step of the plan completed, yet the perceived verdict stayed false over " +
                     std::to_string(final_frames_) + " frames of the final state");
  }
  if (phase_ != Phase::AwaitingPerception) return {};
  if (!awaiting_perception_) return request_plan("a scene estimate came", now);
  const Advice advice = *awaiting_perception_;
  return ground_and_dispatch(advice, now);
}

bool EpisodeMachine::wait_for_perception(const std::optional<Advice>& advice, Clock::time_point now) {
  if (!world_) return false;
  Observation seen = last_obs_;
  const auto unseen = world_->view(seen, {});
  if (!unseen || !unseen->estimate_missing_or_stale) return false;
  if (phase_ != Phase::AwaitingPerception) {
    perception_wait_until_ = now + config_.perception->wait;
    evidence_.append("governor", "awaiting_perception",
                     {{"step", last_obs_.step}, {"reason", unseen->reason}, {"for", advice ? "grounding" : "planning"}});
  }
  if (now >= perception_wait_until_) return false;
  phase_ = Phase::AwaitingPerception;
  awaiting_perception_ = advice;
  deadline_ = perception_wait_until_;
  deadline_what_ = "a fresh scene estimate";
  return true;
}

Effects EpisodeMachine::request_plan(const std::string& why, Clock::time_point now) {
  // Under perception grounding the planner plans on what perception saw: on a real cell the observation
  // has no free objects at all. The frame of this step may still be on its way: wait a little for it.
  if (wait_for_perception(std::nullopt, now)) return {};
  phase_ = Phase::Planning;
  PlanRequestOut r;
  r.index = plans_++;
  r.request_id = spec_.episode_id + "/p" + std::to_string(r.index);
  r.seed = spec_.error_seed;
  r.errors = spec_.planner_errors;
  r.instruction = spec_.instruction;
  r.scene = perceived_scene().entities;
  for (const auto& c : registry_.alive_capabilities())
    if (!config_.masked.count(c)) r.capabilities.push_back(c);
  r.history = history_;
  r.step = last_obs_.step;
  pending_request_ = r.request_id;
  deadline_ = now + config_.planner_timeout;
  deadline_what_ = "planner advice for " + r.request_id;
  deadline_wait_ = "planner";
  evidence_.append("governor", "plan_request",
                   {{"request_id", r.request_id}, {"step", r.step}, {"why", why},
                    {"capabilities", r.capabilities}, {"history_len", r.history.size()}});
  Effects fx;
  fx.plan_request = std::move(r);
  return fx;
}

Effects EpisodeMachine::on_advice(const Advice& advice, Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (phase_ != Phase::Planning || advice.request_id != pending_request_) {
    evidence_.append("governor", "advice_ignored",
                     {{"request_id", advice.request_id}, {"reason", "not the pending request"}});
    return {};
  }
  pending_request_.clear();
  nlohmann::json record{{"request_id", advice.request_id}, {"step", last_obs_.step}, {"refused", advice.refused},
                        {"capability", advice.capability}, {"args", bindings_json(advice.args)},
                        {"rationale", advice.rationale}, {"reason", advice.reason}, {"backend", advice.backend},
                        {"done", advice.done}};
  if (advice.injected != PlannerError::None) record["injected_error"] = to_string(advice.injected);
  evidence_.append("planner", "advice", std::move(record));
  if (advice.done) {
    // The planner judges every step complete. With the latch on, a true verdict would have ended the
    // episode at the last decision; the final state decides without it.
    if (!config_.latch && verdict_now()) return end(true, Outcome::Success, "planner: every step completed; final state satisfies the task");
    if (config_.verifier == Verifier::Perception) {
      // The perceived verdict lags the world by its frames (the hand leaves the object last): wait for it.
      phase_ = Phase::Verifying;
      verifying_from_ = last_obs_.step;
      final_frames_ = 0;
      deadline_ = now + config_.verdict_wait;
      evidence_.append("governor", "awaiting_verdict", {{"step", last_obs_.step}, {"frames", config_.verdict_frames}});
      return {};
    }
    return end(false, Outcome::GaveUp, "planner: every step of the plan completed, yet the task verdict is false");
  }
  if (config_.mode == ExecutorMode::Seq && sequence_.empty() && commands_ == 0) sequence_ = advice.rest;
  set_step(advice);
  return ground_and_dispatch(advice, now);
}

Effects EpisodeMachine::ground_and_dispatch(const Advice& advice, Clock::time_point now) {
  const std::uint32_t remaining = spec_.budget_steps > last_obs_.step ? spec_.budget_steps - last_obs_.step : 0;
  const std::string command_id = spec_.episode_id + "/c" + std::to_string(commands_);
  Observation seen = last_obs_;
  seen.goal_holds = verdict_now();  // the task_goal_unmet precondition reads the episode's verifier
  std::optional<Unperceived> unseen;
  if (world_ && !advice.refused) {
    std::vector<std::string> needed;
    for (const auto& [role, value] : advice.args) needed.push_back(value);
    unseen = world_->view(seen, needed);
    // The frame of this step may still be on its way: wait a little for it (the robot is not moving).
    if (unseen && unseen->estimate_missing_or_stale && wait_for_perception(advice, now)) return {};
  }
  GroundingResult g = unseen ? GroundingResult{std::nullopt, Refusal::Perception, unseen->reason}
                             : ground({advice, registry_, seen, remaining, config_.masked, command_id,
                                      config_.decision_period, spec_.library, spec_.library_costs});
  if (!advice.refused) tried_[history::signature(advice.args)].insert(advice.capability);
  if (!g.command) {
    // An episode can reach this governor before the policy's announcement does (they travel on different
    // topics); the bare arm, which has nothing else to run, waits for it a little.
    if (config_.mode == ExecutorMode::Bare && now < capability_wait_until_ &&
        (g.refusal == Refusal::UnknownCapability || g.refusal == Refusal::CapabilityNotAlive)) {
      if (phase_ != Phase::AwaitingCapability)
        evidence_.append("governor", "awaiting_capability", {{"step", last_obs_.step}, {"reason", g.reason}});
      phase_ = Phase::AwaitingCapability;
      deadline_ = std::min(capability_wait_until_, now + std::chrono::milliseconds(50));
      deadline_what_ = "announcement of '" + advice.capability + "'";
      return {};
    }
    if (config_.mode == ExecutorMode::Bare) {
      evidence_.append("governor", "refusal", {{"step", last_obs_.step}, {"refusal", to_string(g.refusal)},
                                               {"reason", g.reason}, {"capability", advice.capability}});
      return end(false, Outcome::GaveUp, "bare arm: nothing but the policy may act, and " + g.reason);
    }
    // Another capability would not see the scene any better than this one.
    if (is_planner(g.refusal) || g.refusal == Refusal::Budget || g.refusal == Refusal::Perception)
      return refuse(g.refusal, g.reason, now);
    // The advised capability cannot serve this step here: the executor decides what instead.
    ++refusals_total_;
    ++refusals_in_row_;
    evidence_.append("governor", "refusal",
                     {{"step", last_obs_.step}, {"refusal", to_string(g.refusal)}, {"reason", g.reason},
                      {"capability", advice.capability}});
    history_.push_back(history::outcome_line(last_obs_.step, advice.capability, "refused", advice.args, g.reason));
    if (!recovering_) count_failure();
    if (refusals_in_row_ >= config_.max_refusals)
      return end(false, Outcome::GaveUp, std::to_string(refusals_in_row_) + " refusals in a row; last: " + g.reason);
    return decide_now(CommandPhase::Refused, "grounding refused: " + g.reason, now);
  }
  ++commands_;
  refusals_in_row_ = 0;
  if (config_.mode == ExecutorMode::Bare) g.command->budget_steps = remaining;  // the rest of the episode
  g.command->decision_period = config_.decision_period;
  g.command->perception = config_.perception;
  const Command& c = *g.command;
  record_dispatch(c);
  history_.push_back("step " + std::to_string(last_obs_.step) + ": dispatched " + c.capability + " " +
                     history::signature(c.args));
  running_ = c;
  acknowledged_ = false;
  deferred_end_.reset();
  last_progress_ = 0;
  progress_reports_.clear();
  progress_at_decision_ = 0;
  stagnant_ = 0;
  phase_ = Phase::Running;
  deadline_ = now + config_.ack_timeout;
  deadline_what_ = "acknowledgement of '" + c.command_id + "' from " + c.instance;
  deadline_wait_ = "acknowledgement";
  Effects fx;
  fx.lease = Lease{c.command_id, c.lease_until_step, c.start_step + c.budget_steps, false};
  fx.command = c;
  return fx;
}

Effects EpisodeMachine::refuse(Refusal r, const std::string& reason, Clock::time_point now) {
  recovering_ = false;  // the planner is asked again: an interrupted step is not resumed
  resume_.reset();
  ++refusals_total_;
  ++refusals_in_row_;
  evidence_.append("governor", "refusal",
                   {{"step", last_obs_.step}, {"refusal", to_string(r)}, {"reason", reason},
                    {"in_row", refusals_in_row_}});
  history_.push_back("step " + std::to_string(last_obs_.step) + ": refused (" + to_string(r) + "): " + reason);
  if (refusals_in_row_ >= config_.max_refusals)
    return end(false, Outcome::GaveUp, std::to_string(refusals_in_row_) + " refusals in a row; last: " + reason);
  return request_plan(std::string("refusal: ") + to_string(r), now);
}

Effects EpisodeMachine::on_status(const CommandStatus& st, Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (phase_ != Phase::Running || !running_ || st.command_id != running_->command_id) return {};
  const bool terminal = st.state != CommandState::Accepted && st.state != CommandState::Running;
  // An end decided on now (its step observed) is recorded after the decision is made, by finish_command.
  const bool decided_now = terminal && st.step <= last_obs_.step;
  if ((!acknowledged_ || terminal) && !decided_now) record_status(st);
  acknowledged_ = true;
  progress_reports_.emplace_back(st.step, st.progress);
  if (!terminal) {
    await_observation(now);
    return raise_budget(st);
  }
  // Decide on the observation of the step the command ended at (DDS does not order two topics).
  if (st.step > last_obs_.step) {
    deferred_end_ = st;
    return {};
  }
  return finish_command(st, now, true);
}

Effects EpisodeMachine::raise_budget(const CommandStatus& st) {
  Command& c = *running_;
  const std::uint32_t remaining = spec_.budget_steps > c.start_step ? spec_.budget_steps - c.start_step : 0;
  const std::uint32_t budget = raised_budget(c.budget_steps, st.planned_steps, remaining);
  if (budget == c.budget_steps) return {};
  evidence_.append("governor", "budget_raised",
                   {{"step", st.step},
                    {"command_id", c.command_id},
                    {"planned_steps", st.planned_steps},
                    {"from", c.budget_steps},
                    {"to", budget}});
  c.budget_steps = budget;
  // At once, not at the next decision: the capability spends the old budget meanwhile. The governor is
  // alive to say so: the lease runs a decision period from the step it has seen.
  Effects fx;
  fx.lease = Lease{c.command_id, std::max(c.lease_until_step, last_obs_.step + config_.decision_period),
                   c.start_step + c.budget_steps, false};
  return fx;
}

void EpisodeMachine::record_status(const CommandStatus& st) {
  evidence_.append(st.instance.empty() ? "capability" : st.instance, "command_status",
                   {{"step", st.step}, {"command_id", st.command_id}, {"state", to_string(st.state)},
                    {"reason", st.reason}, {"failure", to_string(st.failure)}, {"stage", st.stage},
                    {"steps_used", st.steps_used}, {"progress", st.progress}});
}

Effects EpisodeMachine::finish_command(const CommandStatus& st, Clock::time_point now, bool unrecorded) {
  take_progress(st.step, true);
  CommandPhase phase = CommandPhase::Failed;
  if (st.state == CommandState::Completed) phase = CommandPhase::Completed;
  else if (st.state == CommandState::Refused) {
    phase = CommandPhase::Refused;
    ++refusals_total_;
  }
  else if (st.state == CommandState::Expired) phase = CommandPhase::Expired;
  if (phase != CommandPhase::Completed && !recovering_) count_failure();
  if (phase != CommandPhase::Completed) last_failure_ = st.failure;
  return decide_now(phase, std::string("command ") + to_string(st.state), now, {nullptr, &st, unrecorded});
}

Effects EpisodeMachine::on_capability_lost(const std::string& instance, Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (phase_ == Phase::Ended) return {};  // the episode's record is closed
  evidence_.append("governor", "capability_lost", {{"step", last_obs_.step}, {"instance", instance}});
  if (phase_ != Phase::Running || !running_ || running_->instance != instance) return {};
  if (!recovering_) count_failure();
  history_.push_back(history::outcome_line(last_obs_.step, running_->capability, "lost", running_->args,
                                           "liveliness lease expired"));
  return decide_now(CommandPhase::Lost, "capability instance " + instance + " lost its liveliness", now);
}

bool EpisodeMachine::verdict_now() const {
  return config_.verifier == Verifier::Perception ? perceived_->value() : last_obs_.goal_holds;
}

void EpisodeMachine::on_verdict(std::uint32_t step, const std::string& predicate, bool value) {
  if (config_.verifier == Verifier::Oracle) latch_.record(step, value);
  evidence_.append("sim_worker", "verdict_event", {{"step", step}, {"predicate", predicate}, {"value", value}});
}

Effects EpisodeMachine::on_seam_event(const SeamEvent& e) {
  evidence_.append("seam", to_string(e.kind), {{"step", e.step}, {"command_id", e.command_id}, {"reason", e.reason}});
  if (e.kind != SeamEventKind::Ended || phase_ == Phase::Ended) return {};
  return end(false, Outcome::Infrastructure, "the robot seam ended the episode: " + e.reason);
}

void EpisodeMachine::take_progress(std::uint32_t step, bool through) {
  std::erase_if(progress_reports_, [&](const auto& r) {
    if (through ? r.first > step : r.first >= step) return false;
    last_progress_ = std::max(last_progress_, r.second);
    return true;
  });
}

void EpisodeMachine::set_step(Advice advice) {
  step_signature_ = history::signature(advice.args);
  step_key_ = advice.capability + " " + step_signature_;
  last_advice_ = std::move(advice);
}

void EpisodeMachine::await_observation(Clock::time_point now) {
  deadline_ = now + config_.step_stall_timeout;
  // The text is made once per command: each dispatch waits for its acknowledgement first, so an
  // observation wait already set is this command's.
  if (deadline_wait_ == "observation") return;
  deadline_what_ = "next observation while '" + running_->command_id + "' runs";
  deadline_wait_ = "observation";
}

void EpisodeMachine::count_failure() { ++failures_[step_key_]; }

bool EpisodeMachine::eligible(const std::string& capability) const {
  return !config_.masked.count(capability) && registry_.newest_alive(capability);
}

std::optional<std::string> EpisodeMachine::substitute() const {
  if (!last_advice_) return std::nullopt;
  const auto subs = config_.substitutes.find(last_advice_->capability);
  if (subs == config_.substitutes.end()) return std::nullopt;
  const auto tried = tried_.find(step_signature_);
  for (const auto& c : subs->second)
    if (eligible(c) && (tried == tried_.end() || !tried->second.count(c))) return c;
  return std::nullopt;
}

std::string EpisodeMachine::recovery_for() const {
  const bool holding = last_obs_.holding();
  const bool one_finger = last_obs_.contact_left != last_obs_.contact_right;
  const bool grasp_lost = last_failure_ == FailureCode::GraspMissed || last_failure_ == FailureCode::GraspSlipped ||
                          last_failure_ == FailureCode::ObjectDropped;
  const bool has_object = !recovery_object().empty();
  // A misaligned contact is re-seated, a missed or lost grasp taken again (the interrupted pick and place
  // then goes on from the lift); otherwise let go of what is held, or go back to a safe pose.
  if (has_object && one_finger && eligible("reseat")) return "reseat";
  if (has_object && grasp_lost && !holding && eligible("regrasp")) return "regrasp";
  return holding ? "release_retreat" : "keyframe_return";
}

std::string EpisodeMachine::recovery_object() const {
  if (!last_advice_) return "";
  for (const auto& [role, entity] : last_advice_->args)
    if (role == "object") return entity;
  return "";
}

Effects EpisodeMachine::decide_now(CommandPhase phase, const std::string& cause, Clock::time_point now,
                                   DecidedOn on) {
  const std::uint32_t k = decisions_++;
  DecisionState s;
  s.mode = config_.mode;
  s.latch_enabled = config_.latch;
  s.latched = latch_.decide(last_obs_.step);
  s.phase = phase;
  s.step = last_obs_.step;
  s.budget_steps = spec_.budget_steps;
  if (phase == CommandPhase::Running) {
    // Stagnation: the command's reported progress did not grow since the previous decision.
    stagnant_ = last_progress_ > progress_at_decision_ ? 0 : stagnant_ + 1;
    progress_at_decision_ = last_progress_;
  }
  s.progress = last_progress_;
  s.stagnant_decisions = stagnant_;
  static const std::string kNone;
  const std::string& cap = running_ ? running_->capability : last_advice_ ? last_advice_->capability : kNone;
  const std::string& sig = step_signature_;
  const auto failures = failures_.find(step_key_);
  s.failures_of_step = failures == failures_.end() ? 0 : failures->second;
  s.replans_used = replans_;
  s.was_recovery = recovering_;
  const auto recoveries = recoveries_.find(sig);
  s.recoveries_left = (recoveries == recoveries_.end() ? 0 : recoveries->second) < config_.max_recoveries;
  s.other_instance_alive = running_ && registry_.newest_alive(cap);
  s.substitute_available = substitute().has_value();
  s.recovery_available = eligible(recovery_for());
  const auto tried = tried_.find(sig);
  s.vla_available = eligible("vla_act") && cap != "vla_act" && !(tried != tried_.end() && tried->second.count("vla_act"));
  s.sequence_left = !sequence_.empty();
  const Decision d = decide(s, config_.limits);
  // The decision is made; what follows records it (and the observation it was made on, before it).
  const auto decided = std::chrono::steady_clock::now();
  if (on.ended) {
    if (on.ended_unrecorded) record_status(*on.ended);
    history_.push_back(history::outcome_line(on.ended->step, running_->capability, to_string(on.ended->state),
                                             running_->args, on.ended->reason));
  }
  if (on.observed) evidence_.append("governor", "observation", obs_summary(*on.observed));
  evidence_.append("governor", "decision",
                   {{"k", k}, {"step", s.step}, {"cause", cause}, {"phase", to_string(phase)},
                    {"decision", to_string(d.kind)}, {"reason", d.reason}, {"latched", s.latched},
                    {"progress", s.progress}, {"stagnant", s.stagnant_decisions},
                    {"failures", s.failures_of_step}, {"capability", cap},
                    {"command_id", running_ ? running_->command_id : ""}, {"state", to_json(s)},
                    // From the triggering event's arrival at this core to this decision, its recording
                    // aside (real time, whatever clock the event's `now` is on: the in-process bus runs on
                    // a step clock).
                    {"latency_ns", std::chrono::duration_cast<std::chrono::nanoseconds>(decided - arrived_).count()}});
  Effects fx;
  const auto fast = [&](Advice a) {
    a.refused = false;
    a.done = false;
    a.rationale = "fast brain: " + d.reason;
    return a;
  };
  switch (d.kind) {
    case DecisionKind::Continue: {
      fx.lease = Lease{running_->command_id, s.step + config_.decision_period,
                       running_->start_step + running_->budget_steps, false};
      return fx;
    }
    case DecisionKind::StopSuccess:
      return end(true, Outcome::Success, d.reason + " (predicate first held at step " +
                                      std::to_string(latch_.event_step()) + ")");
    case DecisionKind::GiveUp:
      return end(false, s.step >= s.budget_steps ? Outcome::BudgetExhausted : Outcome::GaveUp, d.reason);
    case DecisionKind::Retry: {
      const Effects stop = stop_command();
      return then(stop, last_advice_ ? ground_and_dispatch(*last_advice_, now) : request_plan(d.reason, now));
    }
    case DecisionKind::Resume: {
      const Effects stop = stop_command();
      recovering_ = false;
      if (resume_) set_step(fast(*resume_));
      resume_.reset();
      return then(stop, last_advice_ ? ground_and_dispatch(*last_advice_, now) : request_plan(d.reason, now));
    }
    case DecisionKind::Substitute: {
      const Effects stop = stop_command();
      Advice a = fast(*last_advice_);
      a.capability = *substitute();
      set_step(a);
      return then(stop, ground_and_dispatch(a, now));
    }
    case DecisionKind::HandToVla: {
      const Effects stop = stop_command();
      Advice a = fast(*last_advice_);
      tried_[sig].insert("vla_act");  // this step is handed over once
      a.capability = "vla_act";
      a.args = {{"instruction", spec_.instruction}};  // the policy was trained on whole instructions
      set_step(a);
      return then(stop, ground_and_dispatch(a, now));
    }
    case DecisionKind::InsertRecovery: {
      const Effects stop = stop_command();
      resume_ = last_advice_;
      ++recoveries_[sig];
      recovering_ = true;
      Advice r = fast(Advice{});
      r.capability = recovery_for();
      if (r.capability == "regrasp" || r.capability == "reseat") r.args = {{"object", recovery_object()}};
      return then(stop, ground_and_dispatch(r, now));
    }
    case DecisionKind::NextInSequence: {
      const Effects stop = stop_command();
      Advice a = fast(Advice{});
      a.capability = sequence_.front().capability;
      a.args = sequence_.front().args;
      sequence_.erase(sequence_.begin());
      set_step(a);
      return then(stop, ground_and_dispatch(a, now));
    }
    case DecisionKind::RequestReplan: {
      if (phase != CommandPhase::Completed) ++replans_;  // nominal next-step requests are not replans
      recovering_ = false;  // a replan abandons an interrupted step
      resume_.reset();
      const Effects stop = stop_command();
      return then(stop, request_plan(d.reason, now));
    }
  }
  return fx;
}

Effects EpisodeMachine::stop_command() {
  Effects fx;
  if (running_) {
    fx.cancel_command = running_->command_id;
    fx.lease = Lease{running_->command_id, last_obs_.step, last_obs_.step, true};
    running_.reset();
  }
  return fx;
}

void record_request(EvidenceWriter& evidence, const std::string& suite, std::uint32_t task, std::uint64_t seed,
                    const std::string& cell, const std::string& arm, const std::string& robot,
                    const PlannerErrorRates& planner_errors) {
  nlohmann::json fields{{"suite", suite}, {"task", task}, {"seed", seed}, {"cell", cell}, {"arm", arm},
                        {"build", build_info().str()}};
  if (!robot.empty()) fields["robot"] = robot;
  if (!planner_errors.none())
    fields["planner_errors"] = {{"wrong_capability", planner_errors.wrong_capability},
                                {"wrong_argument", planner_errors.wrong_argument},
                                {"dropped_step", planner_errors.dropped_step},
                                {"repeated_step", planner_errors.repeated_step}};
  evidence.append("governor", "episode_request", std::move(fields));
}

Effects EpisodeMachine::then(const Effects& first, Effects next) {
  if (!next.cancel_command) next.cancel_command = first.cancel_command;
  // A later lease supersedes an earlier one (a new command's, a revocation) on the channel's lease key.
  if (!next.lease) next.lease = first.lease;
  if (!next.command) next.command = first.command;
  if (!next.plan_request) next.plan_request = first.plan_request;
  if (!next.end) next.end = first.end;
  return next;
}

nlohmann::json EpisodeMachine::perceived_verdict_end(std::uint32_t step) {
  nlohmann::json out = {{"step", step}, {"value", perceived_->value()}, {"oracle", last_obs_.goal_holds}};
  Observation seen = last_obs_;
  if (const auto why = world_->view(seen, {})) {
    out["unperceived"] = why->reason;
    return out;
  }
  nlohmann::json terms = nlohmann::json::array();
  const std::vector<TermCheck> checks = check_terms(spec_.goal, seen, last_obs_);
  for (std::size_t i = 0; i < checks.size(); ++i) {
    const TermCheck& c = checks[i];
    // Where the subject is: an articulated part's joint, otherwise its bottom centre.
    const auto where = [articulated = spec_.goal[i].articulated()](const EntityState* e) {
      if (!e) return nlohmann::json(nullptr);
      return articulated ? nlohmann::json(e->joint) : nlohmann::json{e->p[0], e->p[1], e->p[2]};
    };
    nlohmann::json t = {{"term", c.term}, {"perceived", c.perceived}, {"seen", where(c.seen)}};
    if (c.on_true_poses) t.update({{"on_true_poses", *c.on_true_poses}, {"true", where(c.truth)}});
    if (c.seen && !spec_.goal[i].articulated())
      t["seen_half"] = {c.seen->half_extents[0], c.seen->half_extents[1], c.seen->half_extents[2]};
    if (const auto at = world_->placement(c.subject))
      t["seen_from"] = {{"step", at->step}, {"released", at->released}};
    if (c.support_seen) t["support_seen"] = where(c.support_seen);
    if (c.support_truth) t["support_true"] = where(c.support_truth);
    terms.push_back(std::move(t));
  }
  out["terms"] = std::move(terms);
  return out;
}

Effects EpisodeMachine::end(bool success, Outcome outcome_in, const std::string& reason) {
  Effects fx = stop_command();
  Outcome outcome = outcome_in;
  // Without the latch the benchmark's verdict on the final state decides (unless infrastructure failed).
  if (!config_.latch && !lost_to_infrastructure(outcome)) {
    success = verdict_now();
    if (success) outcome = Outcome::Success;
  }
  phase_ = Phase::Ended;
  EpisodeEnd e{success, last_obs_.step, outcome, reason, decisions_, refusals_total_, capabilities_missing_};
  evidence_.append("governor", "episode_end",
                   {{"step", e.steps}, {"success", success}, {"outcome", to_string(outcome)}, {"reason", reason},
                    {"latched", latch_.latched()}, {"verdict_step", latch_.event_step()},
                    {"decisions", decisions_}, {"refusals", refusals_total_}});
  if (perceived_) evidence_.append("governor", "perceived_verdict_end", perceived_verdict_end(e.steps));
  fx.end = e;
  return fx;
}

Effects EpisodeMachine::on_tick(Clock::time_point now) {
  arrived_ = std::chrono::steady_clock::now();
  if (phase_ == Phase::Ended || now < deadline_) return {};
  if (phase_ == Phase::AwaitingCapability) return ground_and_dispatch(*last_advice_, now);  // refused once the wait is over
  if (phase_ == Phase::AwaitingPerception) {
    if (!awaiting_perception_) return request_plan("the wait for a scene estimate is over", now);
    const Advice advice = *awaiting_perception_;
    return ground_and_dispatch(advice, now);  // refused: the wait is over
  }
  if (phase_ == Phase::Verifying)
    return end(false, Outcome::Infrastructure,
               "perception: " + std::to_string(final_frames_) + " of the " +
                   std::to_string(config_.verdict_wait_frames) + " frames of the final state the perceived verdict " +
                   "waits for came in " + std::to_string(config_.verdict_wait.count()) + " ms");
  const std::string what = deadline_what_;
  evidence_.append("governor", "deadline_missed",
                   {{"step", last_obs_.step}, {"wait", deadline_wait_}, {"waiting_for", what}});
  switch (phase_) {
    case Phase::WaitingFirstObservation:
      return end(false, Outcome::Infrastructure, "no " + what);
    case Phase::AwaitingCapability:
    case Phase::AwaitingPerception:
    case Phase::Verifying:
      break;  // handled above
    case Phase::Planning:
      pending_request_.clear();
      return refuse(Refusal::PlannerUnavailable, "planner timeout: no " + what, now);
    case Phase::Running:
      if (!acknowledged_) {
        if (!recovering_) count_failure();
        return decide_now(CommandPhase::Failed, "no " + what, now);
      }
      return end(false, Outcome::Infrastructure, "no " + what);
    case Phase::Ended:
      break;
  }
  return {};
}

void EpisodeMachine::record_dispatch(const Command& c) {
  evidence_.append("governor", "grounding",
                   {{"step", last_obs_.step}, {"result", "grounded"}, {"command_id", c.command_id},
                    {"capability", c.capability}, {"instance", c.instance}, {"version", c.version},
                    {"args", bindings_json(c.args)},
                    {"theta", c.theta}});
  evidence_.append("governor", "dispatch",
                   {{"step", last_obs_.step}, {"command_id", c.command_id}, {"instance", c.instance},
                    {"budget_steps", c.budget_steps}, {"lease_until_step", c.lease_until_step}});
}

}  // namespace dh::gov
