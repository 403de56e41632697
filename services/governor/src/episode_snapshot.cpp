// The episode machine's snapshot and restore (episode.hpp). Enumerations are stored as their values: a
// snapshot is read by the build that wrote it (replay and the probe refuse another build's evidence).
// Doubles round-trip exactly through nlohmann::json, so a restored machine decides as the original would.
#include <stdexcept>

#include "dh/gov/episode.hpp"

// The plain messages the machine holds, field by field under their own names (nlohmann's macros; a
// Bindings is an array of [role, entity] pairs, an enumeration its value).
namespace dh {
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(EntityState, name, kind, p, q, half_extents, joint, category, colour,
                                   owner, relation)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(GoalTerm, predicate, args, part, lo, hi)
}  // namespace dh

namespace dh::gov {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(PlanStep, capability, args)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(Advice, request_id, refused, capability, args, rationale, reason, backend,
                                   done, rest, injected)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(CommandStatus, command_id, instance, state, reason, stage, step,
                                   steps_used, progress, failure)
// A command's perception limits are an optional, stored beside it (limits_json).
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(Command, command_id, capability, instance, version, args, theta,
                                   start_step, budget_steps, lease_until_step, decision_period)

namespace {

using nlohmann::json;

// The channel is where the episode ran, not its state: left out.
json observation_state(const Observation& o) {
  return {{"step", o.step},
          {"budget_steps", o.budget_steps},
          {"ee_p", o.ee_p},
          {"ee_q", o.ee_q},
          {"gripper_opening", o.gripper_opening},
          {"contacts", {o.contact_left, o.contact_right}},
          {"base_p", o.base_p},
          {"q", o.q},
          {"dq", o.dq},
          {"entities", o.entities},
          {"goal_holds", o.goal_holds},
          {"episode_id", o.episode_id}};
}

Observation observation_from(const json& j) {
  Observation o;
  o.step = j.at("step");
  o.budget_steps = j.at("budget_steps");
  o.ee_p = j.at("ee_p");
  o.ee_q = j.at("ee_q");
  o.gripper_opening = j.at("gripper_opening");
  o.contact_left = j.at("contacts").at(0);
  o.contact_right = j.at("contacts").at(1);
  o.base_p = j.at("base_p");
  o.q = j.at("q");
  o.dq = j.at("dq");
  o.entities = j.at("entities").get<std::vector<EntityState>>();
  o.goal_holds = j.at("goal_holds");
  o.episode_id = j.at("episode_id");
  return o;
}

json spec_state(const EpisodeSpec& s) {
  const PlannerErrorRates& e = s.planner_errors;
  json j{{"episode_id", s.episode_id},
         {"instruction", s.instruction},
         {"arm", s.arm},
         {"budget_steps", s.budget_steps},
         {"library_version", s.library_version},
         {"library", s.library},
         {"library_costs", s.library_costs},
         {"error_seed", s.error_seed},
         {"planner_errors", {e.wrong_capability, e.wrong_argument, e.dropped_step, e.repeated_step}},
         {"goal", s.goal}};
  if (s.decision_period) j["decision_period"] = *s.decision_period;
  if (s.grounding) j["grounding"] = *s.grounding;
  if (s.perception) j["perception"] = limits_json(*s.perception);
  return j;
}

EpisodeSpec spec_from(const json& j) {
  EpisodeSpec s;
  s.episode_id = j.at("episode_id");
  s.instruction = j.at("instruction");
  s.arm = j.at("arm");
  s.budget_steps = j.at("budget_steps");
  s.library_version = j.at("library_version");
  s.library = j.at("library").get<std::map<std::string, std::map<std::string, double>>>();
  s.library_costs = j.at("library_costs").get<std::map<std::string, std::uint32_t>>();
  s.error_seed = j.at("error_seed");
  const json& e = j.at("planner_errors");
  s.planner_errors = {e.at(0), e.at(1), e.at(2), e.at(3)};
  s.goal = j.at("goal").get<std::vector<GoalTerm>>();
  if (j.contains("decision_period")) s.decision_period = j.at("decision_period").get<std::uint32_t>();
  if (j.contains("grounding")) s.grounding = j.at("grounding").get<std::string>();
  if (j.contains("perception")) s.perception = limits_from(j.at("perception"));
  return s;
}

template <class T>
json optional_state(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}

template <class T>
std::optional<T> optional_from(const json& j) {
  return j.is_null() ? std::nullopt : std::optional<T>(j.get<T>());
}

json command_state(const std::optional<Command>& c) {
  json j = optional_state(c);
  if (c && c->perception) j["perception"] = limits_json(*c->perception);
  return j;
}

std::optional<Command> command_from(const json& j) {
  std::optional<Command> c = optional_from<Command>(j);
  if (c && j.contains("perception")) c->perception = limits_from(j.at("perception"));
  return c;
}

std::int64_t left_ns(Clock::time_point until, Clock::time_point now) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(until - now).count();
}

Clock::time_point at(const json& waits, const char* key, Clock::time_point now) {  // key: ns left
  return now + std::chrono::duration_cast<Clock::duration>(
                   std::chrono::nanoseconds(waits.at(key).get<std::int64_t>()));
}

}  // namespace

MachineSnapshot EpisodeMachine::snapshot(Clock::time_point now) const {
  json progress = json::array();
  for (const auto& [step, p] : progress_reports_) progress.push_back({step, p});
  json s{{"format", 1},
         {"spec", spec_state(spec_)},
         {"phase", static_cast<int>(phase_)},
         {"deadline_wait", deadline_wait_},
         {"last_obs", have_obs_ ? observation_state(last_obs_) : json(nullptr)},
         {"awaiting_perception", optional_state(awaiting_perception_)},
         {"latch", latch_.state()},
         {"last_advice", optional_state(last_advice_)},
         {"step_signature", step_signature_},
         {"step_key", step_key_},
         {"resume", optional_state(resume_)},
         {"sequence", sequence_},
         {"tried", tried_},
         {"recoveries", recoveries_},
         {"recovering", recovering_},
         {"running", command_state(running_)},
         {"deferred_end", optional_state(deferred_end_)},
         {"acknowledged", acknowledged_},
         {"last_progress", last_progress_},
         {"progress_at_decision", progress_at_decision_},
         {"progress_reports", std::move(progress)},
         {"stagnant", stagnant_},
         {"failures", failures_},
         {"last_failure", static_cast<int>(last_failure_)},
         {"history", history_},
         {"pending_request", pending_request_},
         {"decisions", decisions_},
         {"refusals_total", refusals_total_},
         {"refusals_in_row", refusals_in_row_},
         {"replans", replans_},
         {"plans", plans_},
         {"commands", commands_}};
  if (world_) s["perceived_world"] = world_->state();
  if (perceived_) {
    const PerceivedVerdict::State v = perceived_->state();
    s["perceived_verdict"] = {{"value", v.value}, {"run", v.run}, {"last_step", optional_state(v.last_step)}};
  }
  return {std::move(s),
          {{"deadline", left_ns(deadline_, now)},
           {"deadline_what", deadline_what_},
           {"capability_wait_until", left_ns(capability_wait_until_, now)},
           {"perception_wait_until", left_ns(perception_wait_until_, now)}}};
}

EpisodeMachine::EpisodeMachine(EpisodeSpec spec, const GovernorConfig& config, const Registry& registry,
                               EvidenceWriter& evidence)
    : spec_(std::move(spec)), config_(config), registry_(registry), evidence_(evidence) {}

EpisodeSpec snapshot_spec(const MachineSnapshot& snap) {
  try {
    if (snap.state.at("format").get<int>() != 1)
      throw std::invalid_argument("snapshot format " + snap.state.at("format").dump() +
                                  " is not this build's (1)");
    return spec_from(snap.state.at("spec"));
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("an episode machine's snapshot that cannot be read: ") +
                                e.what());
  }
}

std::unique_ptr<EpisodeMachine> EpisodeMachine::restore(const MachineSnapshot& snap, std::uint32_t channel,
                                                        const GovernorConfig& config,
                                                        const Registry& registry, EvidenceWriter& evidence,
                                                        Clock::time_point now) {
  EpisodeSpec spec = snapshot_spec(snap);
  spec.channel = channel;
  const json& s = snap.state;
  try {
    if (s.contains("perceived_world") != config.perception.has_value())
      throw std::invalid_argument("the snapshot of " + spec.episode_id + " was taken grounding in " +
                                  (s.contains("perceived_world") ? "perception" : "state") +
                                  ", and its arm now grounds in " +
                                  (config.perception ? "perception" : "state"));
    std::unique_ptr<EpisodeMachine> m(new EpisodeMachine(std::move(spec), config, registry, evidence));
    if (config.perception)
      m->world_ = PerceivedWorld::from_state(s.at("perceived_world"), *config.perception);
    if (s.contains("perceived_verdict")) {
      const json& v = s.at("perceived_verdict");
      m->perceived_.emplace(m->spec_.goal, config.verdict_frames);
      m->perceived_->restore({v.at("value"), v.at("run"), optional_from<std::uint32_t>(v.at("last_step"))});
    }
    m->phase_ = static_cast<Phase>(s.at("phase").get<int>());
    m->deadline_what_ = snap.waits.at("deadline_what");
    m->deadline_wait_ = s.at("deadline_wait");
    m->have_obs_ = !s.at("last_obs").is_null();
    if (m->have_obs_) {
      m->last_obs_ = observation_from(s.at("last_obs"));
      m->last_obs_.channel = channel;
    }
    m->awaiting_perception_ = optional_from<Advice>(s.at("awaiting_perception"));
    m->latch_ = VerdictLatch::from_state(s.at("latch"));
    m->last_advice_ = optional_from<Advice>(s.at("last_advice"));
    m->step_signature_ = s.at("step_signature");
    m->step_key_ = s.at("step_key");
    m->resume_ = optional_from<Advice>(s.at("resume"));
    m->sequence_ = s.at("sequence").get<std::vector<PlanStep>>();
    m->tried_ = s.at("tried").get<std::map<std::string, std::set<std::string>>>();
    m->recoveries_ = s.at("recoveries").get<std::map<std::string, int>>();
    m->recovering_ = s.at("recovering");
    m->running_ = command_from(s.at("running"));
    m->deferred_end_ = optional_from<CommandStatus>(s.at("deferred_end"));
    m->acknowledged_ = s.at("acknowledged");
    m->last_progress_ = s.at("last_progress");
    m->progress_at_decision_ = s.at("progress_at_decision");
    for (const auto& r : s.at("progress_reports")) m->progress_reports_.emplace_back(r.at(0), r.at(1));
    m->stagnant_ = s.at("stagnant");
    m->failures_ = s.at("failures").get<std::map<std::string, int>>();
    m->last_failure_ = static_cast<FailureCode>(s.at("last_failure").get<int>());
    m->history_ = s.at("history").get<std::vector<std::string>>();
    m->pending_request_ = s.at("pending_request");
    m->decisions_ = s.at("decisions");
    m->refusals_total_ = s.at("refusals_total");
    m->refusals_in_row_ = s.at("refusals_in_row");
    m->replans_ = s.at("replans");
    m->plans_ = s.at("plans");
    m->commands_ = s.at("commands");
    m->deadline_ = at(snap.waits, "deadline", now);
    m->capability_wait_until_ = at(snap.waits, "capability_wait_until", now);
    m->perception_wait_until_ = at(snap.waits, "perception_wait_until", now);
    return m;
  } catch (const json::exception& e) {
    throw std::invalid_argument(std::string("an episode machine's snapshot that cannot be read: ") +
                                e.what());
  }
}

Effects EpisodeMachine::redispatch(const std::string& library_version,
                                   const std::map<std::string, std::map<std::string, double>>& library,
                                   const std::map<std::string, std::uint32_t>& library_costs,
                                   std::uint32_t budget_steps, Clock::time_point now) {
  if (phase_ != Phase::Running || !running_)
    throw std::logic_error("redispatch: episode " + spec_.episode_id + " runs no command");
  // The recording's instance ran in another process: the command goes to this registry's.
  const CapabilityInfo* info = registry_.newest_alive(running_->capability);
  if (!info) throw std::logic_error("redispatch: no live instance of '" + running_->capability + "'");
  spec_.library_version = library_version;
  spec_.library = library;
  spec_.library_costs = library_costs;
  // As grounding does: the library's θ, else the instance's own.
  const auto theta = library.find(running_->capability);
  running_->theta = theta != library.end() ? theta->second : info->parameters;
  running_->budget_steps = budget_steps;
  running_->instance = info->instance;
  running_->version = info->version;
  acknowledged_ = false;
  deadline_ = now + config_.ack_timeout;
  deadline_what_ = "acknowledgement of '" + running_->command_id + "' from " + running_->instance;
  deadline_wait_ = "acknowledgement";
  record_dispatch(*running_);
  Effects fx;
  fx.lease =
      Lease{running_->command_id, running_->lease_until_step, running_->start_step + budget_steps, false};
  fx.command = running_;
  return fx;
}

}  // namespace dh::gov
