// One capability family as its own process: the DDS shell around HostCore (host_core.hpp, which lists the
// ports and holds every rule). This file adds what only a process has: the announcement of each capability
// on rt/dh/capability/announce (transient-local, liveliness MANUAL_BY_TOPIC, lease 1 s), asserted only while
// the event loop runs: a loop stuck in a skill longer than its capabilities declare they may block it
// (CapabilityDef::blocks_up_to) loses the lease and the governor counts the instance lost;
// and draining on SIGTERM/SIGINT: the announcement says so (the governor sends new commands elsewhere), new
// commands are refused, and running ones finish (at most --drain-timeout-s) before it exits — how `dh swap`
// replaces it without losing a command.
#include "dh/cap/host.hpp"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <optional>
#include <variant>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/host_core.hpp"
#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace dh::cap {
namespace {

using Event = std::variant<msg::Command, msg::Observation, msg::SceneEstimate>;

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

/// Publishes what the core decided, in its order, and logs every command's end.
class Publisher {
 public:
  Publisher(dds::Participant& p, spdlog::logger& log)
      : log_(log), action_(p, topics::kAction, dds::Qos::Action), status_(p, topics::kCommandStatus, dds::Qos::Status) {}

  void operator()(const HostEffects& fx) {
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
      status_.write(s);
      if (ended(r.state))
        log_.info("channel={} command={} {} at step {} {}", r.channel, r.command_id, to_string(r.state), r.step, r.reason);
    }
    for (const auto& x : fx.actions) {
      msg::Action a;
      a.channel(x.channel);
      a.episode_id(x.episode_id);
      a.command_id(x.command_id);
      a.step(x.step);
      std::copy_n(x.a.begin(), 7, a.a().begin());
      action_.write(a);
    }
  }

 private:
  spdlog::logger& log_;
  dds::Writer<msg::ActionPubSubType> action_;
  dds::Writer<msg::CommandStatusPubSubType> status_;
};

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

/// The host's readers, made on activate and removed on deactivate; every message goes to `q`.
struct Readers {
  Readers(dds::Participant& p, EventQueue<Event>& q)
      : command(p, topics::kCommand, dds::Qos::Command, {[&q](const msg::Command& m, const auto&) { q.push(m); }, {}, {}}),
        observation(p, topics::kObservation, dds::Qos::Observation,
                    {[&q](const msg::Observation& m, const auto&) { q.push(m); }, {}, {}}),
        scene(p, topics::kSceneEstimate, dds::Qos::Observation,
              {[&q](const msg::SceneEstimate& m, const auto&) { q.push(m); }, {}, {}}) {}
  dds::Reader<msg::CommandPubSubType> command;
  dds::Reader<msg::ObservationPubSubType> observation;
  dds::Reader<msg::SceneEstimatePubSubType> scene;
};

}  // namespace

int run_capability_host(int argc, char** argv, const std::string& family, std::vector<CapabilityDef> capabilities) {
  return run_capability_host(argc, argv, family, [](CLI::App&) {}, [&] { return std::move(capabilities); });
}

int run_capability_host(int argc, char** argv, const std::string& family,
                        const std::function<void(CLI::App&)>& add_options,
                        const std::function<std::vector<CapabilityDef>()>& make) {
  const std::string service = "dh_cap_" + family;
  CLI::App app{service + ": capability family '" + family + "'"};
  std::vector<std::string> libraries;
  unsigned drain_timeout_s = 30;
  app.add_option("--library", libraries,
                 "capability descriptor YAML, one per capability served (default: configs/library/<capability>.yaml)");
  app.add_option("--drain-timeout-s", drain_timeout_s, "on a stop, how long running commands may take to finish");
  add_options(app);
  CLI11_PARSE(app, argc, argv);
  auto log = make_logger(service);
  EventQueue<Event> queue;  // declared first: the readers that push into it go before it
  std::vector<Served> served;
  std::optional<dds::Participant> participant;
  std::optional<HostCore> core;
  std::optional<Publisher> publish;
  std::optional<dds::Writer<msg::CapabilityAnnouncePubSubType>> announce;
  std::optional<Readers> readers;
  std::optional<dds::Heartbeat> alive;
  // The loop beats each turn; the heartbeat asserts liveliness while the last beat is recent enough.
  std::atomic<Clock::rep> beat{Clock::now().time_since_epoch().count()};
  const auto assert_every = std::chrono::milliseconds(static_cast<int>(dds::kLivelinessLeaseSec * 1000 / 4));
  const auto announce_all = [&] {
    for (const auto& s : served) announce->write(s.descriptor);
  };

  ManagedService m;
  m.transitions.configure = [&] {
    char host[256] = "";
    gethostname(host, sizeof host - 1);
    for (const auto& def : make()) {
      std::filesystem::path file = default_descriptor_file(def.name);
      for (const auto& l : libraries)
        if (ConfigNode::load_file(l).get<std::string>("capability") == def.name) file = l;
      const std::string instance = def.name + "@" + std::string(host) + ":" + std::to_string(getpid());
      served.push_back({def, announcement(load_descriptor(file, def), instance)});
    }
    std::vector<ServedCapability> cores;
    for (const auto& s : served) cores.push_back({s.def, s.descriptor.instance()});
    core.emplace(std::move(cores));  // θ and the perception limits arrive with each command
    participant.emplace(service);
    publish.emplace(*participant, *log);
    announce.emplace(*participant, topics::kAnnounce, dds::Qos::Announce);
  };
  m.transitions.activate = [&] {
    readers.emplace(*participant, queue);
    announce_all();
    for (const auto& s : served)
      log->info("instance={} cost_steps={} announced", s.descriptor.instance(), s.descriptor.cost_steps());
    auto allowance = assert_every;
    for (const auto& s : served) allowance = std::max(allowance, s.def.blocks_up_to + assert_every);
    beat = Clock::now().time_since_epoch().count();
    alive.emplace(
        [&, allowance] {
          if (Clock::now() - Clock::time_point(Clock::duration(beat.load())) <= allowance) announce->assert_liveliness();
        },
        assert_every);
  };
  // New commands are refused from here on; the announcement tells the governor to send them elsewhere.
  m.transitions.drain = [&] {
    core->drain();
    for (auto& s : served) s.descriptor.draining(true);
    announce_all();
    log->info("family={} draining: {} command(s) running", family, core->running());
  };
  m.transitions.deactivate = [&] {
    if (core->running() > 0) log->warn("family={} stops with {} command(s) running", family, core->running());
    alive.reset();
    readers.reset();
  };
  m.transitions.shutdown = [&] {
    alive.reset();
    readers.reset();
    announce.reset();
    publish.reset();
    participant.reset();
    core.reset();
  };
  m.step = [&] {
    if (auto e = queue.pop(std::chrono::milliseconds(50))) {
      const auto now = Clock::now();
      if (const auto* c = std::get_if<msg::Command>(&*e)) {
        if (c->kind() == msg::COMMAND_CANCEL)
          (*publish)(core->on_cancel({c->channel(), c->episode_id(), c->command_id(), c->instance()}));
        else
          (*publish)(core->on_start(from_msg(*c), now));
      } else if (const auto* o = std::get_if<msg::Observation>(&*e)) {
        (*publish)(core->on_observation(convert::from_msg(*o), now));
      } else if (const auto* sc = std::get_if<msg::SceneEstimate>(&*e)) {
        (*publish)(core->on_scene_estimate(sc->channel(), convert::from_msg(*sc), now));
      }
    }
    (*publish)(core->on_tick(Clock::now()));
    beat = Clock::now().time_since_epoch().count();
  };
  m.drained = [&] { return core->running() == 0; };
  m.drain_timeout = std::chrono::seconds(drain_timeout_s);
  return run_managed(*log, std::move(m));
}

}  // namespace dh::cap
