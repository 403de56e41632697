// dh_governor: the DDS shell around gov::GovernorCore (core.hpp), the fast brain and the execution
// contract's writer side, one EpisodeMachine per channel.
//
// Reads   rt/dh/episode/request (Episode)     starts a channel's episode
//         rt/dh/observation     (Observation) every step; decisions every 10th
//         rt/dh/planner/advice  (Planner)
//         rt/dh/command/status  (Status)
//         rt/dh/capability/announce (Announce, liveliness 1 s: a lost lease marks the instance dead)
//         rt/dh/verdict, rt/dh/seam/event     recorded and latched
//         rt/dh/command         (Command)     commands it did not write are recorded as foreign
//         rt/dh/perception/scene (Observation) scene estimates, for arms that ground from perception
// Writes  rt/dh/planner/request (Planner), rt/dh/command (Command), rt/dh/lease (Lease, deadline 1 s;
//         the running episode's lease is written again every 250 ms, so the seam hears a live governor),
//         rt/dh/episode/result  (Episode), rt/dh/evidence (Episode: each channel's episode as its evidence
//         stands, for live views)
// Evidence: one JSON-lines file per episode under --runs-dir/evidence/.
// Parameters: --config FILE (default configs/governor.yaml), --runs-dir DIR (default DH_RUNS_DIR or ./runs),
// --planner-timeout-ms N (overrides the YAML's planner_timeout_ms).
#include <CLI/CLI.hpp>

#include <map>
#include <optional>
#include <variant>

#include "dh/common/arms.hpp"
#include "dh/gov/config.hpp"
#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/gov/core.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace dh {
namespace {

struct Announced {
  msg::CapabilityAnnounce a;
  dds::fdds::InstanceHandle_t writer;
};
struct LivelinessChange {
  dds::fdds::InstanceHandle_t writer;
  bool alive;
};
/// A command on the command topic that this governor did not write.
struct ForeignCommand {
  msg::Command c;
};
using Event = std::variant<msg::EpisodeRequest, msg::Observation, msg::Advice, msg::CommandStatus, Announced,
                           LivelinessChange, msg::Verdict, msg::SeamEvent, ForeignCommand, msg::SceneEstimate>;

gov::EpisodeRequest from_msg(const msg::EpisodeRequest& r) {
  gov::EpisodeRequest q;
  q.channel = r.channel();
  q.episode_id = r.episode_id();
  q.instruction = r.instruction();
  q.arm = r.arm();
  q.suite = r.suite();
  q.cell = r.cell();
  q.task = r.task();
  q.seed = r.seed();
  q.budget_steps = r.budget_steps();
  q.library_version = r.library_version();
  for (const auto& c : r.library()) q.library[c.capability()] = convert::from_msg(c.parameters());
  if (r.decision_period_steps() > 0) q.decision_period = r.decision_period_steps();
  if (!r.grounding().empty()) q.grounding = r.grounding();
  if (r.perception().max_age_steps() > 0) q.perception = convert::from_msg(r.perception());
  q.planner_errors = convert::from_msg(r.planner_errors());
  return q;
}

/// The DDS shell around gov::GovernorCore: converts messages to the core's events and carries out its
/// effects on the writers, in the order the core gives them.
class Shell {
 public:
  Shell(dds::Participant& p, gov::GovernorCore& core, std::shared_ptr<spdlog::logger> log)
      : core_(core), log_(std::move(log)), plan_(p, topics::kPlanRequest, dds::Qos::Planner),
        command_(p, topics::kCommand, dds::Qos::Command), lease_(p, topics::kLease, dds::Qos::Lease),
        result_(p, topics::kEpisodeResult, dds::Qos::Episode), live_(p, topics::kEvidence, dds::Qos::Episode) {}

  void handle(const msg::EpisodeRequest& r) {
    log_->info("channel={} episode={} requested (arm {})", r.channel(), r.episode_id(), r.arm());
    carry_out(core_.on_request(from_msg(r), gov::Clock::now()));
  }
  void handle(const msg::Observation& m) { carry_out(core_.on_observation(convert::from_msg(m), gov::Clock::now())); }
  void handle(const msg::Advice& a) {
    gov::Advice adv{a.request_id(), a.refused(), a.capability(), convert::from_msg(a.args()), a.rationale(),
                    a.reason(), a.backend(), a.done(), {}};
    for (const auto& st : a.rest()) adv.rest.push_back({st.capability(), convert::from_msg(st.args())});
    adv.injected = convert::from_msg(a.injected());
    carry_out(core_.on_advice(a.channel(), a.episode_id(), adv, gov::Clock::now()));
  }
  void handle(const msg::CommandStatus& s) {
    gov::CommandStatus st{s.command_id(), s.instance(), static_cast<gov::CommandState>(s.state()), s.reason(),
                          s.stage(), s.step(), s.steps_used(), s.progress(), static_cast<FailureCode>(s.failure())};
    carry_out(core_.on_status(s.channel(), s.episode_id(), st, gov::Clock::now()));
  }
  void handle(const Announced& a) {
    gov::CapabilityInfo info{a.a.capability(), a.a.instance(), a.a.version(), a.a.arguments(), a.a.preconditions(),
                             convert::from_msg(a.a.parameters()), a.a.cost_steps(), a.a.started_ns(), true,
                             a.a.draining()};
    writers_[a.writer] = info.instance;
    core_.on_announce(info);
    log_->info("capability={} instance={} announced (cost {} steps){}", info.capability, info.instance, info.cost_steps,
               info.draining ? ", draining" : "");
  }
  void handle(const LivelinessChange& c) {
    const auto it = writers_.find(c.writer);
    if (it == writers_.end()) return;
    if (c.alive) log_->info("instance={} liveliness asserted", it->second);
    else log_->warn("instance={} liveliness lost", it->second);
    carry_out(core_.on_liveliness(it->second, c.alive, gov::Clock::now()));
  }
  void handle(const msg::Verdict& v) { core_.on_verdict(v.channel(), v.episode_id(), v.step(), v.predicate(), v.value()); }
  void handle(const msg::SeamEvent& e) {
    core_.on_seam_event(e.channel(), e.episode_id(),
                        {e.step(), e.command_id(), static_cast<SeamEventKind>(e.kind()), e.reason(), {}});
  }
  void handle(const msg::SceneEstimate& m) {
    carry_out(core_.on_scene_estimate(m.channel(), convert::from_msg(m), gov::Clock::now()));
  }
  /// Only this governor commands capabilities: a command from anyone else is recorded (capabilities may
  /// start on it, but the seam applies no action of a command this governor did not lease).
  void handle(const ForeignCommand& f) {
    const auto& c = f.c;
    log_->warn("channel={} foreign command rejected: {}", c.channel(),
               core_.on_foreign_command(c.channel(), c.episode_id(), c.command_id(), c.capability()));
  }
  void tick() { carry_out(core_.on_tick(gov::Clock::now())); }
  /// The channels whose episode state is news, for live views.
  void write_live() {
    for (const auto& s : core_.take_live()) {
      msg::EpisodeLive m;
      m.channel(s.channel);
      m.episode_id(s.episode_id);
      m.arm(s.arm);
      m.cell(s.cell);
      m.task(s.task);
      m.seed(s.seed);
      m.step(s.step);
      m.budget_steps(s.budget_steps);
      m.capability(s.capability);
      m.decision(s.decision);
      m.reason(s.reason);
      m.ended(s.ended);
      m.outcome(s.outcome);
      m.evidence_path(s.evidence.string());
      live_.write(m);
    }
  }
  dds::fdds::InstanceHandle_t command_writer() const { return command_.handle(); }

 private:
  void carry_out(const gov::CoreEffects& effects) {
    for (const auto& e : effects) carry_out(e);
  }
  void carry_out(const gov::ChannelEffects& e) {
    const auto& fx = e.fx;
    if (fx.cancel_command) {
      msg::Command c;
      c.channel(e.channel);
      c.episode_id(e.episode_id);
      c.command_id(*fx.cancel_command);
      c.kind(msg::COMMAND_CANCEL);
      c.instance(e.cancel_instance);
      command_.write(c);
    }
    if (fx.lease) {
      msg::Lease l;
      l.channel(e.channel);
      l.episode_id(e.episode_id);
      l.command_id(fx.lease->command_id);
      l.valid_until_step(fx.lease->valid_until_step);
      l.budget_until_step(fx.lease->budget_until_step);
      l.revoked(fx.lease->revoked);
      lease_.write(l);
    }
    if (fx.command) {
      const auto& g = *fx.command;
      msg::Command c;
      c.channel(e.channel);
      c.episode_id(e.episode_id);
      c.command_id(g.command_id);
      c.kind(msg::COMMAND_START);
      c.capability(g.capability);
      c.instance(g.instance);
      c.args(convert::to_msg(g.args));
      c.theta(convert::to_msg(g.theta));
      c.start_step(g.start_step);
      c.budget_steps(g.budget_steps);
      c.lease_until_step(g.lease_until_step);
      c.grounding(g.perception ? "perception" : "state");
      if (g.perception) c.perception(convert::to_msg(*g.perception));
      c.decision_period(g.decision_period);
      command_.write(c);
      log_->info("channel={} dispatch {} -> {} budget={}", e.channel, g.command_id, g.instance, g.budget_steps);
    }
    if (fx.plan_request) {
      const auto& r = *fx.plan_request;
      msg::PlanRequest m;
      m.channel(e.channel);
      m.request_id(r.request_id);
      m.episode_id(e.episode_id);
      m.instruction(r.instruction);
      for (const auto& s : r.scene) m.entities().push_back(s.name);
      m.scene(convert::to_msg(r.scene));
      m.capabilities(r.capabilities);
      m.history(r.history);
      m.step(r.step);
      m.seed(r.seed);
      m.index(r.index);
      m.errors(convert::to_msg(r.errors));
      plan_.write(m);
    }
    if (fx.end) {
      const auto& end = *fx.end;
      msg::EpisodeResult r;
      r.channel(e.channel);
      r.episode_id(e.episode_id);
      r.success(end.success);
      r.steps(end.steps);
      r.outcome(static_cast<msg::Outcome>(end.outcome));
      r.reason(end.reason);
      r.evidence_path(e.evidence.string());
      r.decisions(end.decisions);
      r.refusals(end.refusals);
      result_.write(r);
      const auto level = end.outcome == Outcome::Rejected ? spdlog::level::warn : spdlog::level::info;
      log_->log(level, "channel={} episode={} outcome={} steps={} reason={} evidence={}", e.channel, e.episode_id,
                to_string(end.outcome), end.steps, end.reason, e.evidence.string());
    }
  }

  gov::GovernorCore& core_;
  std::shared_ptr<spdlog::logger> log_;
  dds::Writer<msg::PlanRequestPubSubType> plan_;
  dds::Writer<msg::CommandPubSubType> command_;
  dds::Writer<msg::LeasePubSubType> lease_;
  dds::Writer<msg::EpisodeResultPubSubType> result_;
  dds::Writer<msg::EpisodeLivePubSubType> live_;
  std::map<dds::fdds::InstanceHandle_t, std::string> writers_;  ///< announcing writer -> instance
};

/// The governor's readers, made on activate and removed on deactivate; every message goes to `q`.
struct Readers {
  template <class PubSub>
  using R = dds::Reader<PubSub>;
  Readers(dds::Participant& p, EventQueue<Event>& q, dds::fdds::InstanceHandle_t own_commands)
      : request(p, topics::kEpisodeRequest, dds::Qos::Episode, {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        observation(p, topics::kObservation, dds::Qos::Observation,
                    {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        advice(p, topics::kAdvice, dds::Qos::Planner, {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        status(p, topics::kCommandStatus, dds::Qos::Status, {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        announce(p, topics::kAnnounce, dds::Qos::Announce,
                 {[&q](const msg::CapabilityAnnounce& m, const dds::fdds::SampleInfo& i) {
                    q.push(Announced{m, i.publication_handle});
                  },
                  [&q](const dds::fdds::LivelinessChangedStatus& s) {
                    // Lost: an alive writer turned not alive (its lease expired) or went away (its
                    // participant's lease expired or it was deleted).
                    if (s.not_alive_count_change > 0 || s.alive_count_change < 0)
                      q.push(LivelinessChange{s.last_publication_handle, false});
                    if (s.alive_count_change > 0) q.push(LivelinessChange{s.last_publication_handle, true});
                  },
                  {}}),
        verdict(p, topics::kVerdict, dds::Qos::Verdict, {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        seam(p, topics::kSeamEvent, dds::Qos::Status, {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        scene(p, topics::kSceneEstimate, dds::Qos::Observation,
              {[&q](const auto& m, const auto&) { q.push(m); }, {}, {}}),
        command(p, topics::kCommand, dds::Qos::Command,
                {[&q, own_commands](const msg::Command& m, const dds::fdds::SampleInfo& i) {
                   if (i.publication_handle != own_commands) q.push(ForeignCommand{m});
                 },
                 {},
                 {}}) {}
  R<msg::EpisodeRequestPubSubType> request;
  R<msg::ObservationPubSubType> observation;
  R<msg::AdvicePubSubType> advice;
  R<msg::CommandStatusPubSubType> status;
  R<msg::CapabilityAnnouncePubSubType> announce;
  R<msg::VerdictPubSubType> verdict;
  R<msg::SeamEventPubSubType> seam;
  R<msg::SceneEstimatePubSubType> scene;
  R<msg::CommandPubSubType> command;
};

int run(int argc, char** argv) {
  CLI::App app{"dh_governor: fast brain and execution contract"};
  std::string config, runs;
  app.add_option("--config", config, "governor YAML (default: configs/governor.yaml)");
  app.add_option("--runs-dir", runs, "where evidence goes (default: DH_RUNS_DIR or ./runs)");
  std::optional<unsigned> planner_timeout_ms;
  app.add_option("--planner-timeout-ms", planner_timeout_ms,
                 "overrides planner_timeout_ms of the YAML (a model server's planner needs more than its own timeout)");
  unsigned ready_timeout_ms = 3000;
  app.add_option("--ready-timeout-ms", ready_timeout_ms,
                 "after start, an episode waits at most this long for the capabilities it may use to announce");
  CLI11_PARSE(app, argc, argv);
  auto log = make_logger("dh_governor");
  if (config.empty()) config = (paths::config_dir() / "governor.yaml").string();
  const std::filesystem::path runs_dir =
      std::filesystem::absolute(runs.empty() ? paths::runs_dir() : std::filesystem::path(runs));
  EventQueue<Event> q;  // declared first: the readers that push into it go before it
  std::optional<dds::Participant> participant;
  std::optional<gov::GovernorCore> core;
  std::optional<Shell> shell;
  std::optional<Readers> readers;
  auto next_tick = gov::Clock::now();
  ManagedService service;
  service.transitions.configure = [&] {
    gov::GovernorConfig gc = gov::load_config(config);
    if (planner_timeout_ms) gc.planner_timeout = std::chrono::milliseconds(*planner_timeout_ms);
    // The lease topic's deadline tells the seam this governor is alive: a running episode's lease is
    // written again well within it.
    const auto lease_rewrite = std::chrono::milliseconds(static_cast<int>(dds::kLeaseDeadlineSec * 1000 / 4));
    core.emplace(gc, load_arms(config),
                 gov::CoreSettings{runs_dir, gov::Clock::now() + std::chrono::milliseconds(ready_timeout_ms),
                                   lease_rewrite});
    participant.emplace("dh_governor");
    shell.emplace(*participant, *core, log);
  };
  service.transitions.activate = [&] {
    readers.emplace(*participant, q, shell->command_writer());
    log->info("domain={} runs={} up", dds::domain_id(), runs_dir.string());
  };
  service.transitions.deactivate = [&] { readers.reset(); };
  service.transitions.shutdown = [&] {
    readers.reset();
    shell.reset();
    participant.reset();
    core.reset();
  };
  service.step = [&] {
    if (auto e = q.pop(std::chrono::milliseconds(20))) std::visit([&](auto& ev) { shell->handle(ev); }, *e);
    if (gov::Clock::now() >= next_tick) {
      shell->tick();
      next_tick = gov::Clock::now() + std::chrono::milliseconds(50);
    }
    shell->write_live();
  };
  return run_managed(*log, std::move(service));
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
