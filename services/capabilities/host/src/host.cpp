// One capability family as its own process: HostCore (host_core.hpp, which lists the ports and holds every
// rule) run by the one DDS shell (dds_shell.hpp). This binding adds what only a process has: the
// announcement of each capability on rt/dh/capability/announce (transient-local, liveliness MANUAL_BY_TOPIC,
// lease 1 s), which the shell asserts only while the loop turns: a loop stuck in a skill longer than its
// capabilities declare they may block it (CapabilityDef::blocks_up_to) loses the lease and the governor
// counts the instance lost; and draining on SIGTERM/SIGINT: the announcement says so (the governor sends new
// commands elsewhere), new commands are refused, and running ones finish (at most --drain-timeout-s) before
// it exits — how `dh swap` replaces it without losing a command.
#include "dh/cap/host.hpp"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/host_core.hpp"
#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/common/paths.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace dh::cap {
namespace {

using dds::In;

struct Served {
  CapabilityDef def;
  msg::CapabilityAnnounce descriptor;
};

CommandStart from_msg(const msg::Command& c) {
  CommandStart s;
  s.channel = c.channel();
  s.episode_id = c.episode_id();
  s.command_id = c.command_id();
  s.capability = c.capability();
  s.instance = c.instance();
  s.args = convert::from_msg(c.args());
  s.theta = convert::from_msg(c.theta());
  s.start_step = c.start_step();
  s.budget_steps = c.budget_steps();
  s.decision_period = c.decision_period();
  s.grounding = c.grounding() == "perception" ? Grounding::Perception : Grounding::State;
  s.perception = convert::from_msg(c.perception());
  return s;
}

msg::CapabilityAnnounce announcement(const Descriptor& d, const std::string& instance) {
  msg::CapabilityAnnounce a;
  a.capability(d.capability);
  a.instance(instance);
  a.version(d.version);
  a.arguments(d.arguments);
  a.preconditions(d.preconditions);
  a.cost_steps(static_cast<std::uint32_t>(d.cost_steps));
  a.parameters(convert::to_msg(d.parameters));
  a.started_ns(static_cast<unsigned long long>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count()));
  return a;
}

class HostBinding {
 public:
  using Inputs = dds::Inputs<In<port::Command>, In<port::Observation, dds::kAddressed>,
                             In<port::SceneEstimate>, In<port::Lease>>;
  using Outputs = dds::Outputs<port::Action, port::CommandStatus, port::Announce>;
  using Context = dds::Context<HostBinding>;

  HostBinding(std::string family, std::function<void(CLI::App&)> add_options,
              std::function<std::vector<CapabilityDef>()> make)
      : family_(std::move(family)), add_options_(std::move(add_options)), make_(std::move(make)) {}

  std::string name() const { return "dh_cap_" + family_; }
  std::string description() const { return "capability family '" + family_ + "'"; }
  const Ports& ports() const { return HostCore::ports(); }
  void options(CLI::App& app) {
    app.add_option("--library", libraries_,
                   "capability descriptor YAML, one per capability served (default: configs/library/<capability>.yaml)");
    app.add_option("--drain-timeout-s", drain_timeout_s_, "on a stop, how long running commands may take to finish");
    add_options_(app);
  }

  void configure(Context&) {
    char host[256] = "";
    gethostname(host, sizeof host - 1);
    for (const auto& def : make_()) {
      std::filesystem::path file = default_descriptor_file(def.name);
      for (const auto& l : libraries_)
        if (ConfigNode::load_file(l).get<std::string>("capability") == def.name) file = l;
      const std::string instance = def.name + "@" + std::string(host) + ":" + std::to_string(getpid());
      served_.push_back({def, announcement(load_descriptor(file, def), instance)});
    }
    std::vector<ServedCapability> cores;
    for (const auto& s : served_) cores.push_back({s.def, s.descriptor.instance()});
    core_.emplace(std::move(cores));  // θ and the perception limits arrive with each command
  }
  void activate(Context& ctx) {
    announce_all(ctx);
    for (const auto& s : served_)
      ctx.log.info("instance={} cost_steps={} announced", s.descriptor.instance(), s.descriptor.cost_steps());
  }
  /// A skill may hold the loop up to what its capability declares; the lease is kept that long.
  std::chrono::milliseconds loop_allowance() const {
    std::chrono::milliseconds a{0};
    for (const auto& s : served_) a = std::max(a, std::chrono::duration_cast<std::chrono::milliseconds>(s.def.blocks_up_to));
    return a + std::chrono::milliseconds(static_cast<int>(dds::kLivelinessLeaseSec * 1000 / 4));
  }

  void on(const dds::Sample<port::Command>& s, Context& ctx) {
    const msg::Command& c = s.msg;
    if (c.kind() == msg::COMMAND_CANCEL)
      publish(ctx, core_->on_cancel({c.channel(), c.episode_id(), c.command_id(), c.instance()}));
    else
      publish(ctx, core_->on_start(from_msg(c), Clock::now()));
  }
  void on(const dds::Sample<port::Observation>& s, Context& ctx) {
    publish(ctx, core_->on_observation(convert::from_msg(s.msg), Clock::now()));
  }
  void on(const dds::Sample<port::SceneEstimate>& s, Context& ctx) {
    publish(ctx, core_->on_scene_estimate(s.msg.channel(), convert::from_msg(s.msg), Clock::now()));
  }
  void on(const dds::Sample<port::Lease>& s, Context&) {
    core_->on_lease(s.msg.channel(), s.msg.episode_id(), s.msg.command_id(), s.msg.budget_until_step());
  }
  void tick(Context& ctx) { publish(ctx, core_->on_tick(Clock::now())); }

  // New commands are refused from here on; the announcement tells the governor to send them elsewhere.
  void drain(Context& ctx) {
    core_->drain();
    for (auto& s : served_) s.descriptor.draining(true);
    announce_all(ctx);
    ctx.log.info("family={} draining: {} command(s) running", family_, core_->running());
  }
  bool drained() const { return core_->running() == 0; }
  std::chrono::milliseconds drain_timeout() const { return std::chrono::seconds(drain_timeout_s_); }
  void deactivate(Context& ctx) {
    if (core_->running() > 0) ctx.log.warn("family={} stops with {} command(s) running", family_, core_->running());
  }

 private:
  void announce_all(Context& ctx) {
    for (const auto& s : served_) ctx.write<port::Announce>(s.descriptor);
  }
  /// Writes what the core decided, in its order, and logs every command's end.
  void publish(Context& ctx, const HostEffects& fx) {
    for (const auto& r : fx.statuses) {
      msg::CommandStatus s;
      s.channel(r.channel);
      s.episode_id(r.episode_id);
      s.command_id(r.command_id);
      s.instance(r.instance);
      s.state(static_cast<msg::CommandState>(r.state));
      s.reason(r.reason);
      s.step(r.step);
      s.steps_used(r.steps_used);
      s.progress(r.progress);
      s.stage(r.stage);
      s.failure(static_cast<msg::FailureCode>(r.failure));
      s.planned_steps(r.planned_steps);
      ctx.write<port::CommandStatus>(s);
      if (ended(r.state))
        ctx.log.info("channel={} command={} {} at step {} {}", r.channel, r.command_id, to_string(r.state), r.step, r.reason);
    }
    for (const auto& x : fx.actions) {
      msg::Action a;
      a.channel(x.channel);
      a.episode_id(x.episode_id);
      a.command_id(x.command_id);
      a.step(x.step);
      std::copy_n(x.a.begin(), 7, a.a().begin());
      a.frames(x.frames);
      ctx.write<port::Action>(a);
    }
  }

  std::string family_;
  std::function<void(CLI::App&)> add_options_;
  std::function<std::vector<CapabilityDef>()> make_;
  std::vector<std::string> libraries_;
  unsigned drain_timeout_s_ = 30;
  std::vector<Served> served_;
  std::optional<HostCore> core_;
};

}  // namespace

int run_capability_host(int argc, char** argv, const std::string& family, std::vector<CapabilityDef> capabilities) {
  return run_capability_host(argc, argv, family, [](CLI::App&) {}, [&] { return std::move(capabilities); });
}

int run_capability_host(int argc, char** argv, const std::string& family,
                        const std::function<void(CLI::App&)>& add_options,
                        const std::function<std::vector<CapabilityDef>()>& make) {
  return dds::run_service(argc, argv, HostBinding(family, add_options, make));
}

}  // namespace dh::cap
