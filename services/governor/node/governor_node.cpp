// dh_governor: gov::GovernorCore (core.hpp), the fast brain and the execution contract's writer side, one
// EpisodeMachine per channel, run by the one DDS shell (dds_shell.hpp) through this binding.
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

#include "dh/common/arms.hpp"
#include "dh/gov/config.hpp"
#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/gov/core.hpp"
#include "dh/gov/ports.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace dh {
namespace {

using dds::In;
using dds::Sample;

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
  q.robot = r.robot();
  q.budget_steps = r.budget_steps();
  q.library_version = r.library_version();
  for (const auto& c : r.library()) {
    q.library[c.capability()] = convert::from_msg(c.parameters());
    if (c.cost_steps() > 0) q.library_costs[c.capability()] = c.cost_steps();
  }
  if (r.decision_period_steps() > 0) q.decision_period = r.decision_period_steps();
  if (!r.grounding().empty()) q.grounding = r.grounding();
  if (r.perception().max_age_steps() > 0) q.perception = convert::from_msg(r.perception());
  q.planner_errors = convert::from_msg(r.planner_errors());
  q.goal = convert::from_msg(r.goal());
  q.verifier = convert::from_msg(r.verifier());
  return q;
}

/// gov::GovernorCore's binding: converts messages to the core's events and carries out its effects on the
/// writers, in the order the core gives them.
class GovernorBinding {
 public:
  using Inputs = dds::Inputs<In<port::EpisodeRequest>, In<port::Observation>, In<port::Advice>, In<port::CommandStatus>,
                             In<port::Announce, dds::kLiveliness>, In<port::Verdict>, In<port::SeamEvent>,
                             In<port::SceneEstimate>, In<port::Command, dds::kSkipOwn>>;
  using Outputs = dds::Outputs<port::PlanRequest, port::Command, port::Lease, port::EpisodeResult, port::Evidence>;
  using Context = dds::Context<GovernorBinding>;

  std::string name() const { return "dh_governor"; }
  std::string description() const { return "fast brain and execution contract"; }
  const Ports& ports() const { return gov::ports(); }
  void options(CLI::App& app) {
    app.add_option("--config", config_, "governor YAML (default: configs/governor.yaml)");
    app.add_option("--runs-dir", runs_, "where evidence goes (default: DH_RUNS_DIR or ./runs)");
    app.add_option("--planner-timeout-ms", planner_timeout_ms_,
                   "overrides planner_timeout_ms of the YAML (a model server's planner needs more than its own timeout)");
    app.add_option("--ready-timeout-ms", ready_timeout_ms_,
                   "after start, an episode waits at most this long for the capabilities it may use to announce");
  }
  void configure(Context&) {
    if (config_.empty()) config_ = (paths::config_dir() / "governor.yaml").string();
    runs_dir_ = std::filesystem::absolute(runs_.empty() ? paths::runs_dir() : std::filesystem::path(runs_));
    gov::GovernorConfig gc = gov::load_config(config_);
    if (planner_timeout_ms_) gc.planner_timeout = std::chrono::milliseconds(*planner_timeout_ms_);
    // The lease topic's deadline tells the seam this governor is alive: a running episode's lease is
    // written again well within it.
    const auto lease_rewrite = std::chrono::milliseconds(static_cast<int>(dds::kLeaseDeadlineSec * 1000 / 4));
    core_.emplace(gc, load_arms(config_),
                  gov::CoreSettings{runs_dir_, gov::Clock::now() + std::chrono::milliseconds(ready_timeout_ms_),
                                    lease_rewrite});
  }
  void activate(Context& ctx) { ctx.log.info("domain={} runs={} up", dds::domain_id(), runs_dir_.string()); }
  std::chrono::milliseconds wait() const { return std::chrono::milliseconds(20); }

  void on(const Sample<port::EpisodeRequest>& s, Context& ctx) {
    const auto& r = s.msg;
    ctx.log.info("channel={} episode={} requested (arm {})", r.channel(), r.episode_id(), r.arm());
    carry_out(ctx, core_->on_request(from_msg(r), gov::Clock::now()));
  }
  void on(const Sample<port::Observation>& s, Context& ctx) {
    if (s.msg.again()) return;  // a step said again for a starting command's capability: seen already
    carry_out(ctx, core_->on_observation(convert::from_msg(s.msg), gov::Clock::now()));
  }
  void on(const Sample<port::Advice>& s, Context& ctx) {
    const auto& a = s.msg;
    gov::Advice adv{a.request_id(), a.refused(), a.capability(), convert::from_msg(a.args()), a.rationale(),
                    a.reason(), a.backend(), a.done(), {}};
    for (const auto& st : a.rest()) adv.rest.push_back({st.capability(), convert::from_msg(st.args())});
    adv.injected = convert::from_msg(a.injected());
    adv.why = convert::from_msg(a.refusal());
    carry_out(ctx, core_->on_advice(a.channel(), a.episode_id(), adv, gov::Clock::now()));
  }
  void on(const Sample<port::CommandStatus>& m, Context& ctx) {
    const auto& s = m.msg;
    gov::CommandStatus st{s.command_id(),   s.instance(), static_cast<gov::CommandState>(s.state()),
                          s.reason(),       s.stage(),    s.step(),
                          s.steps_used(),   s.progress(), static_cast<FailureCode>(s.failure()),
                          s.planned_steps()};
    carry_out(ctx, core_->on_status(s.channel(), s.episode_id(), st, gov::Clock::now()));
  }
  void on(const Sample<port::Announce>& s, Context& ctx) {
    const auto& a = s.msg;
    gov::CapabilityInfo info{a.capability(), a.instance(), a.version(), a.arguments(), a.preconditions(),
                             convert::from_msg(a.parameters()), a.cost_steps(), a.started_ns(), true,
                             a.draining()};
    writers_[s.writer] = info.instance;
    core_->on_announce(info);
    ctx.log.info("capability={} instance={} announced (cost {} steps){}", info.capability, info.instance,
                 info.cost_steps, info.draining ? ", draining" : "");
  }
  void on(const dds::LivelinessChanged<port::Announce>& c, Context& ctx) {
    const auto it = writers_.find(c.writer);
    if (it == writers_.end()) return;
    if (c.alive) ctx.log.info("instance={} liveliness asserted", it->second);
    else ctx.log.warn("instance={} liveliness lost", it->second);
    carry_out(ctx, core_->on_liveliness(it->second, c.alive, gov::Clock::now()));
  }
  void on(const Sample<port::Verdict>& s, Context&) {
    const auto& v = s.msg;
    core_->on_verdict(v.channel(), v.episode_id(), v.step(), v.predicate(), v.value());
  }
  void on(const Sample<port::SeamEvent>& s, Context& ctx) {
    const auto& e = s.msg;
    carry_out(ctx, core_->on_seam_event(
                       e.channel(), e.episode_id(),
                       {e.step(), e.command_id(), static_cast<SeamEventKind>(e.kind()), e.reason(), {}},
                       gov::Clock::now()));
  }
  void on(const Sample<port::SceneEstimate>& s, Context& ctx) {
    carry_out(ctx, core_->on_scene_estimate(s.msg.channel(), convert::from_msg(s.msg), gov::Clock::now()));
  }
  /// Only this governor commands capabilities: a command from anyone else (the shell drops this process's
  /// own) is recorded (capabilities may start on it, but the seam applies no action of a command this
  /// governor did not lease).
  void on(const Sample<port::Command>& s, Context& ctx) {
    const auto& c = s.msg;
    ctx.log.warn("channel={} foreign command rejected: {}", c.channel(),
                 core_->on_foreign_command(c.channel(), c.episode_id(), c.command_id(), c.capability()));
  }
  void tick(Context& ctx) {
    if (gov::Clock::now() >= next_tick_) {
      carry_out(ctx, core_->on_tick(gov::Clock::now()));
      next_tick_ = gov::Clock::now() + std::chrono::milliseconds(50);
    }
    write_live(ctx);
  }
  void shutdown() { core_.reset(); }

 private:
  /// The channels whose episode state is news, for live views.
  void write_live(Context& ctx) {
    for (const auto& s : core_->take_live()) {
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
      ctx.write<port::Evidence>(m);
    }
  }

  void carry_out(Context& ctx, const gov::CoreEffects& effects) {
    for (const auto& e : effects) carry_out(ctx, e);
  }
  void carry_out(Context& ctx, const gov::ChannelEffects& e) {
    const auto& fx = e.fx;
    if (fx.cancel_command) {
      msg::Command c;
      c.channel(e.channel);
      c.episode_id(e.episode_id);
      c.command_id(*fx.cancel_command);
      c.kind(msg::COMMAND_CANCEL);
      c.instance(e.cancel_instance);
      ctx.write<port::Command>(c);
    }
    if (fx.lease) {
      msg::Lease l;
      l.channel(e.channel);
      l.episode_id(e.episode_id);
      l.command_id(fx.lease->command_id);
      l.valid_until_step(fx.lease->valid_until_step);
      l.budget_until_step(fx.lease->budget_until_step);
      l.revoked(fx.lease->revoked);
      ctx.write<port::Lease>(l);
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
      ctx.write<port::Command>(c);
      ctx.log.info("channel={} dispatch {} -> {} budget={}", e.channel, g.command_id, g.instance, g.budget_steps);
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
      ctx.write<port::PlanRequest>(m);
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
      r.capabilities_missing(end.capabilities_missing);
      ctx.write<port::EpisodeResult>(r);
      const auto level = end.outcome == Outcome::Rejected ? spdlog::level::warn : spdlog::level::info;
      ctx.log.log(level, "channel={} episode={} outcome={} steps={} reason={} evidence={}", e.channel, e.episode_id,
                to_string(end.outcome), end.steps, end.reason, e.evidence.string());
    }
  }

  std::string config_, runs_;
  std::optional<unsigned> planner_timeout_ms_;
  unsigned ready_timeout_ms_ = 3000;
  std::filesystem::path runs_dir_;
  std::optional<gov::GovernorCore> core_;
  std::map<dds::fdds::InstanceHandle_t, std::string> writers_;  ///< announcing writer -> instance
  gov::Clock::time_point next_tick_ = gov::Clock::now();
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::GovernorBinding{}); }
