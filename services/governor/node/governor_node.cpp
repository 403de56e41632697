// dh_governor: the fast brain and the execution contract's writer side, one EpisodeMachine per channel.
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
//         rt/dh/episode/result  (Episode)
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
#include "dh/gov/episode.hpp"
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

class Governor {
 public:
  Governor(dds::Participant& p, gov::GovernorConfig config, std::map<std::string, ArmSpec> arms,
           std::filesystem::path runs, std::chrono::milliseconds ready_timeout, std::shared_ptr<spdlog::logger> log)
      : config_(std::move(config)), arms_(std::move(arms)), runs_(std::move(runs)), log_(std::move(log)),
        plan_(p, topics::kPlanRequest, dds::Qos::Planner),
        command_(p, topics::kCommand, dds::Qos::Command),
        lease_(p, topics::kLease, dds::Qos::Lease),
        result_(p, topics::kEpisodeResult, dds::Qos::Episode),
        ready_by_(gov::Clock::now() + ready_timeout) {}

  void handle(const msg::EpisodeRequest& r) {
    auto& ch = channels_[r.channel()];
    if (ch.machine && ch.machine->spec().episode_id == r.episode_id()) return;  // redelivery
    if (std::find(done_.begin(), done_.end(), r.episode_id()) != done_.end()) return;
    const std::string arm = r.arm().empty() ? "full" : r.arm();
    gov::EpisodeSpec spec{r.channel(), r.episode_id(), r.instruction(), arm, r.budget_steps(), r.library_version(), {}};
    for (const auto& c : r.library()) spec.library[c.capability()] = convert::from_msg(c.parameters());
    if (r.decision_period_steps() > 0) spec.decision_period = r.decision_period_steps();
    if (!r.grounding().empty()) spec.grounding = r.grounding();
    if (r.perception().max_age_steps() > 0) spec.perception = convert::from_msg(r.perception());
    std::optional<gov::GovernorConfig> episode_config;
    std::string why;
    try {
      episode_config = gov::for_request(gov::for_arm(config_, find_arm(arms_, arm)), spec);
    } catch (const ConfigError& e) {
      why = e.what();
    }
    // Readiness: the episode waits until every capability it may dispatch to has announced an instance
    // that takes commands (they come on discovery, after this governor may have started), at most until
    // --ready-timeout-ms after the start; then it runs with what there is and its evidence says what was
    // missing. A request that names no library cannot say what it needs: it waits for that timeout.
    const bool starting = gov::Clock::now() < ready_by_;
    std::vector<std::string> missing;
    if (episode_config)
      missing = spec.library.empty() ? std::vector<std::string>{"(no library named: every announcement)"}
                                     : registry_.missing(gov::needed_capabilities(*episode_config, spec));
    if (!missing.empty() && starting) {
      held_.push_back(r);
      return;
    }
    if (ch.machine && !ch.machine->ended()) {
      // One client's request must not preempt another's episode.
      const std::string busy = "channel " + std::to_string(r.channel()) + " is busy with episode " +
                               ch.machine->spec().episode_id;
      publish_result(r.channel(), r.episode_id(), {false, 0, Outcome::Rejected, busy, 0, 0}, "");
      log_->warn("channel={} request {} rejected: {}", r.channel(), r.episode_id(), busy);
      return;
    }
    const auto path = paths::evidence_file(runs_, r.episode_id(), ".jsonl");
    ch.machine.reset();
    ch.lease.reset();
    ch.evidence = std::make_unique<EvidenceWriter>(path);
    gov::record_request(*ch.evidence, r.suite(), r.task(), r.seed(), r.cell(), r.arm());
    if (!episode_config) {
      // Answer at once so the client and the simulator channel do not wait for a deadline.
      ch.evidence->append("governor", "episode_rejected", {{"reason", why}});
      publish_result(r.channel(), r.episode_id(), {false, 0, Outcome::Rejected, why, 0, 0}, ch.evidence->path());
      log_->error("channel={} episode={} rejected: {}", r.channel(), r.episode_id(), why);
      return;
    }
    if (!spec.library.empty() && !missing.empty())  // the machine records it
      log_->warn("channel={} episode={} starts without an instance of {}", r.channel(), r.episode_id(),
                 nlohmann::json(missing).dump());
    ch.machine = std::make_unique<gov::EpisodeMachine>(spec, *episode_config, registry_,
                                                       *ch.evidence, gov::Clock::now());
    log_->info("channel={} episode={} arm={} evidence={}", r.channel(), r.episode_id(), arm, path.string());
    if (ch.early && ch.early->episode_id() == r.episode_id()) {
      const msg::Observation first = *ch.early;
      ch.early.reset();
      handle(first);
    }
    if (ch.early_scene && ch.early_scene->episode_id() == r.episode_id()) {
      const msg::SceneEstimate scene = *ch.early_scene;
      ch.early_scene.reset();
      handle(scene);
    }
  }

  void handle(const msg::Observation& m) {
    if (auto* mc = machine(m.channel(), m.episode_id())) {
      apply(m.channel(), mc->on_observation(convert::from_msg(m), gov::Clock::now()));
      return;
    }
    auto& ch = channels_[m.channel()];
    const bool known = (ch.machine && ch.machine->spec().episode_id == m.episode_id()) ||
                       std::find(done_.begin(), done_.end(), m.episode_id()) != done_.end();
    if (!known) ch.early = m;
  }
  void handle(const msg::Advice& a) {
    auto* mc = machine(a.channel(), a.episode_id());
    if (!mc) return;
    gov::Advice adv{a.request_id(), a.refused(), a.capability(), convert::from_msg(a.args()), a.rationale(),
                    a.reason(), a.backend(), a.done(), {}};
    for (const auto& st : a.rest()) adv.rest.push_back({st.capability(), convert::from_msg(st.args())});
    apply(a.channel(), mc->on_advice(adv, gov::Clock::now()));
  }
  void handle(const msg::CommandStatus& s) {
    auto* mc = machine(s.channel(), s.episode_id());
    if (!mc) return;
    gov::CommandStatus st{s.command_id(), s.instance(), static_cast<gov::CommandState>(s.state()), s.reason(),
                          s.stage(), s.step(), s.steps_used(), s.progress(), static_cast<FailureCode>(s.failure())};
    apply(s.channel(), mc->on_status(st, gov::Clock::now()));
  }
  void handle(const Announced& a) {
    gov::CapabilityInfo info{a.a.capability(), a.a.instance(), a.a.version(), a.a.arguments(), a.a.preconditions(),
                             convert::from_msg(a.a.parameters()), a.a.cost_steps(), a.a.started_ns(), true,
                             a.a.draining()};
    writers_[a.writer] = info.instance;
    registry_.announce(info);
    log_->info("capability={} instance={} announced (cost {} steps){}", info.capability, info.instance, info.cost_steps,
               info.draining ? ", draining" : "");
  }
  void handle(const LivelinessChange& c) {
    auto it = writers_.find(c.writer);
    if (it == writers_.end()) return;
    registry_.set_alive(it->second, c.alive);
    if (c.alive) log_->info("instance={} liveliness asserted", it->second);
    else log_->warn("instance={} liveliness lost", it->second);
    if (c.alive) return;
    for (auto& [id, ch] : channels_)
      if (ch.machine) apply(id, ch.machine->on_capability_lost(it->second, gov::Clock::now()));
  }
  void handle(const msg::Verdict& v) {
    if (auto* mc = machine(v.channel(), v.episode_id())) mc->on_verdict(v.step(), v.predicate(), v.value());
  }
  void handle(const msg::SeamEvent& e) {
    if (auto* mc = machine(e.channel(), e.episode_id()))
      mc->on_seam_event({e.step(), e.command_id(), static_cast<SeamEventKind>(e.kind()), e.reason(), {}});
  }
  void handle(const msg::SceneEstimate& m) {
    auto* mc = machine(m.channel(), m.episode_id());
    if (!mc) {
      // The frame of step 0 can be seen before this governor takes the episode's request.
      channels_[m.channel()].early_scene = m;
      return;
    }
    apply(m.channel(), mc->on_scene_estimate(convert::from_msg(m), gov::Clock::now()));
  }
  /// Only this governor commands capabilities: a command from anyone else is recorded (capabilities may
  /// start on it, but the seam applies no action of a command this governor did not lease).
  void handle(const ForeignCommand& f) {
    const auto& c = f.c;
    const bool known = registry_.known(c.capability());
    const std::string why = "command '" + c.command_id() + "' for capability '" + c.capability() +
                            "' was not issued by this governor" +
                            (known ? std::string() : "; no such capability is announced");
    log_->warn("channel={} foreign command rejected: {}", c.channel(), why);
    auto it = channels_.find(c.channel());
    if (it != channels_.end() && it->second.machine && !it->second.machine->ended())
      it->second.evidence->append("governor", "foreign_command",
                                  {{"command_id", c.command_id()}, {"capability", c.capability()},
                                   {"episode_id", c.episode_id()}, {"reason", why}});
  }
  dds::fdds::InstanceHandle_t command_writer() const { return command_.handle(); }
  void tick() {
    if (!held_.empty()) {  // each is held again while it still waits
      auto held = std::move(held_);
      held_.clear();
      for (const auto& r : held) handle(r);
    }
    for (auto& [id, ch] : channels_)
      if (ch.machine && !ch.machine->ended()) apply(id, ch.machine->on_tick(gov::Clock::now()));
    // The lease topic's deadline tells the seam this governor is alive: a running episode's lease is
    // written again well within it, also while no step (and so no renewal) comes.
    const auto now = gov::Clock::now();
    for (auto& [id, ch] : channels_)
      if (ch.lease && ch.machine && !ch.machine->ended() && now - ch.lease_written >= kLeaseRewrite) {
        lease_.write(*ch.lease);
        ch.lease_written = now;
      }
  }

 private:
  struct ChannelState {
    std::unique_ptr<EvidenceWriter> evidence;
    std::unique_ptr<gov::EpisodeMachine> machine;
    /// The simulator answers the same episode request with its first observation, which can reach us
    /// before the request does; it is kept until the request comes.
    std::optional<msg::Observation> early;
    std::optional<msg::SceneEstimate> early_scene;  ///< the same for perception's first scene estimate
    std::optional<msg::Lease> lease;  ///< the last lease written for the running episode
    gov::Clock::time_point lease_written;
  };
  static constexpr auto kLeaseRewrite =
      std::chrono::milliseconds(static_cast<int>(dds::kLeaseDeadlineSec * 1000 / 4));

  gov::EpisodeMachine* machine(std::uint32_t channel, const std::string& episode) {
    auto it = channels_.find(channel);
    if (it == channels_.end() || !it->second.machine || it->second.machine->spec().episode_id != episode ||
        it->second.machine->ended())
      return nullptr;
    return it->second.machine.get();
  }

  void apply(std::uint32_t channel, const gov::Effects& fx) {
    auto& ch = channels_[channel];
    const std::string& episode = ch.machine->spec().episode_id;
    if (fx.cancel_command) {
      msg::Command c;
      c.channel(channel);
      c.episode_id(episode);
      c.command_id(*fx.cancel_command);
      c.kind(msg::COMMAND_CANCEL);
      c.instance(instance_of_.count(*fx.cancel_command) ? instance_of_[*fx.cancel_command] : "");
      command_.write(c);
    }
    if (fx.lease) {
      msg::Lease l;
      l.channel(channel);
      l.episode_id(episode);
      l.command_id(fx.lease->command_id);
      l.valid_until_step(fx.lease->valid_until_step);
      l.budget_until_step(fx.lease->budget_until_step);
      l.revoked(fx.lease->revoked);
      lease_.write(l);
      ch.lease = l;
      ch.lease_written = gov::Clock::now();
    }
    if (fx.command) {
      const auto& g = *fx.command;
      instance_of_[g.command_id] = g.instance;
      msg::Command c;
      c.channel(channel);
      c.episode_id(episode);
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
      log_->info("channel={} dispatch {} -> {} budget={}", channel, g.command_id, g.instance, g.budget_steps);
    }
    if (fx.plan_request) {
      const auto& r = *fx.plan_request;
      msg::PlanRequest m;
      m.channel(channel);
      m.request_id(r.request_id);
      m.episode_id(episode);
      m.instruction(r.instruction);
      for (const auto& e : r.scene) m.entities().push_back(e.name);
      m.scene(convert::to_msg(r.scene));
      m.capabilities(r.capabilities);
      m.history(r.history);
      m.step(r.step);
      plan_.write(m);
    }
    if (fx.end) {
      publish_result(channel, episode, *fx.end, ch.evidence->path());
      log_->info("channel={} episode={} outcome={} steps={} reason={}", channel, episode, to_string(fx.end->outcome),
                 fx.end->steps, fx.end->reason);
    }
  }

  void publish_result(std::uint32_t channel, const std::string& episode, const gov::EpisodeEnd& e,
                      const std::filesystem::path& evidence) {
    msg::EpisodeResult r;
    r.channel(channel);
    r.episode_id(episode);
    r.success(e.success);
    r.steps(e.steps);
    r.outcome(static_cast<msg::Outcome>(e.outcome));
    r.reason(e.reason);
    r.evidence_path(evidence.string());
    r.decisions(e.decisions);
    r.refusals(e.refusals);
    result_.write(r);
    done_.push_back(episode);
    if (done_.size() > 256) done_.erase(done_.begin());
  }

  gov::GovernorConfig config_;
  std::map<std::string, ArmSpec> arms_;
  std::filesystem::path runs_;
  std::shared_ptr<spdlog::logger> log_;
  dds::Writer<msg::PlanRequestPubSubType> plan_;
  dds::Writer<msg::CommandPubSubType> command_;
  dds::Writer<msg::LeasePubSubType> lease_;
  dds::Writer<msg::EpisodeResultPubSubType> result_;
  gov::Registry registry_;
  std::map<dds::fdds::InstanceHandle_t, std::string> writers_;
  std::map<std::string, std::string> instance_of_;
  std::map<std::uint32_t, ChannelState> channels_;
  std::vector<std::string> done_;
  gov::Clock::time_point ready_by_;
  std::vector<msg::EpisodeRequest> held_;
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
  return run_service(*log, [&] {
    if (config.empty()) config = (paths::config_dir() / "governor.yaml").string();
    const std::filesystem::path runs_dir = runs.empty() ? paths::runs_dir() : std::filesystem::path(runs);
    dds::Participant participant("dh_governor");
    gov::GovernorConfig gc = gov::load_config(config);
    if (planner_timeout_ms) gc.planner_timeout = std::chrono::milliseconds(*planner_timeout_ms);
    Governor gov(participant, gc, load_arms(config), std::filesystem::absolute(runs_dir),
                 std::chrono::milliseconds(ready_timeout_ms), log);
    EventQueue<Event> q;
    auto push = [&q](auto m) { q.push(std::move(m)); };
    dds::Reader<msg::EpisodeRequestPubSubType> r1(participant, topics::kEpisodeRequest, dds::Qos::Episode,
        {[&](const msg::EpisodeRequest& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::ObservationPubSubType> r2(participant, topics::kObservation, dds::Qos::Observation,
        {[&](const msg::Observation& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::AdvicePubSubType> r3(participant, topics::kAdvice, dds::Qos::Planner,
        {[&](const msg::Advice& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::CommandStatusPubSubType> r4(participant, topics::kCommandStatus, dds::Qos::Status,
        {[&](const msg::CommandStatus& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::CapabilityAnnouncePubSubType> r5(participant, topics::kAnnounce, dds::Qos::Announce,
        {[&](const msg::CapabilityAnnounce& m, const dds::fdds::SampleInfo& i) { push(Announced{m, i.publication_handle}); },
         [&](const dds::fdds::LivelinessChangedStatus& s) {
           // Lost: an alive writer turned not alive (its lease expired) or went away (its participant's lease
           // expired or it was deleted).
           if (s.not_alive_count_change > 0 || s.alive_count_change < 0)
             push(LivelinessChange{s.last_publication_handle, false});
           if (s.alive_count_change > 0) push(LivelinessChange{s.last_publication_handle, true});
         },
         {}});
    dds::Reader<msg::VerdictPubSubType> r6(participant, topics::kVerdict, dds::Qos::Verdict,
        {[&](const msg::Verdict& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::SeamEventPubSubType> r7(participant, topics::kSeamEvent, dds::Qos::Status,
        {[&](const msg::SeamEvent& m, const auto&) { push(m); }, {}, {}});
    dds::Reader<msg::SceneEstimatePubSubType> r9(participant, topics::kSceneEstimate, dds::Qos::Observation,
        {[&](const msg::SceneEstimate& m, const auto&) { push(m); }, {}, {}});
    const auto own_commands = gov.command_writer();
    dds::Reader<msg::CommandPubSubType> r8(participant, topics::kCommand, dds::Qos::Command,
        {[&](const msg::Command& m, const dds::fdds::SampleInfo& i) {
           if (i.publication_handle != own_commands) push(ForeignCommand{m});
         }, {}, {}});
    log->info("domain={} runs={} up", dds::domain_id(), runs_dir.string());
    auto next_tick = gov::Clock::now();
    while (!shutdown_requested()) {
      if (auto e = q.pop(std::chrono::milliseconds(20))) std::visit([&](auto& ev) { gov.handle(ev); }, *e);
      if (gov::Clock::now() >= next_tick) {
        gov.tick();
        next_tick = gov::Clock::now() + std::chrono::milliseconds(50);
      }
    }
  });
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
