// One capability family as its own process.
//
// Writes  rt/dh/capability/announce (Announce: transient-local, liveliness MANUAL_BY_TOPIC, lease 1 s), one
//                                    sample per capability the family serves
//         rt/dh/action          (Action)  one action per observation while a command runs
//         rt/dh/command/status  (Status)  accepted / refused(reason) / running / completed / failed(reason)
// Reads   rt/dh/command         (Command) START / CANCEL addressed to one of this process's instances;
//                                         every START on a channel also records a keyframe there
//         rt/dh/observation     (Observation)
//         rt/dh/perception/scene (Observation) scene estimates: a command whose `grounding` is "perception"
//                                         moves in the perceived world (dh/common/perceived_world.hpp),
//                                         not among the observation's object poses
// On SIGTERM/SIGINT the process drains: it refuses new commands and finishes the ones running (at most
// --drain-timeout-s), then exits — how `dh swap` replaces it without losing a command.
#include "dh/cap/host.hpp"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <map>
#include <optional>
#include <variant>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/motion.hpp"
#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/perceived_world.hpp"
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

struct Running {
  msg::Command command;
  const Served* served = nullptr;
  std::unique_ptr<Skill> skill;  // set once the command's first observation arrived
  std::uint32_t steps_used = 0;
  std::string stage;
  /// Set while a perceived command waits for a fresh scene estimate (sending no action holds the
  /// lock-stepped channel too, as a robot pauses for its cameras).
  std::optional<std::chrono::steady_clock::time_point> awaiting_frame_since;
};

Bindings bindings(const msg::Command& c) {
  Bindings b;
  for (const auto& x : c.args()) b.emplace_back(x.role(), x.entity());
  return b;
}

std::vector<std::string> bound_entities(const msg::Command& c) {
  std::vector<std::string> e;
  for (const auto& x : c.args()) e.push_back(x.entity());
  return e;
}

/// The deployment's limits on scene estimates: the `perception:` section of the governor's configuration
/// (the same limits for both brains); the defaults where it has none.
PerceptionLimits deployment_perception_limits() {
  const ConfigNode c = ConfigNode::load_file(paths::config_dir() / "governor.yaml");
  return c.has("perception") ? perception_limits(c.child("perception")) : PerceptionLimits{};
}

class Node {
 public:
  Node(dds::Participant& p, const std::vector<Served>& served, PerceptionLimits limits,
       std::shared_ptr<spdlog::logger> log)
      : served_(served), limits_(limits), log_(std::move(log)), action_(p, topics::kAction, dds::Qos::Action),
        status_(p, topics::kCommandStatus, dds::Qos::Status) {}

  void handle(const msg::Command& c) {
    if (c.kind() == msg::COMMAND_START) {
      record_keyframe(c);
      // A newer command on the channel supersedes whatever this process still runs there (its CANCEL may
      // have been overwritten on the channel's key before it was read).
      if (auto it = running_.find(c.channel()); it != running_.end() && it->second.command.command_id() != c.command_id()) {
        cancel(it, "superseded by " + c.command_id());
      }
    }
    const Served* s = find(c.instance());
    if (!s) return;
    if (c.kind() == msg::COMMAND_CANCEL) {
      auto it = running_.find(c.channel());
      if (it != running_.end() && it->second.command.command_id() == c.command_id()) cancel(it, "cancelled by the governor");
      return;
    }
    Running r{c, s, nullptr, 0, "pending", std::nullopt};
    if (draining_) {
      status(r, msg::STATE_REFUSED, "instance " + c.instance() + " is draining (being replaced or stopped)",
             c.start_step(), 0);
      return;
    }
    running_[c.channel()] = std::move(r);
    if (auto o = last_obs_.find(c.channel()); o != last_obs_.end()) handle(o->second);
  }

  void handle(const msg::SceneEstimate& m) {
    worlds_.try_emplace(m.channel(), limits_).first->second.on_estimate(convert::from_msg(m));
    retry_awaiting(m.channel());
  }

  /// Commands waiting for a frame past the deadline give up (called between events).
  void tick() {
    std::vector<std::uint32_t> due;
    for (const auto& [channel, r] : running_)
      if (r.awaiting_frame_since && std::chrono::steady_clock::now() - *r.awaiting_frame_since >= limits_.wait)
        due.push_back(channel);
    for (const auto channel : due) retry_awaiting(channel);
  }

  void handle(const msg::Observation& m) {
    auto& last = last_obs_[m.channel()];
    if (last.episode_id() != m.episode_id()) keyframes_.erase(m.channel());
    last = m;
    Observation obs = convert::from_msg(m);
    // Every observation goes through the channel's perceived world, so it sees each grasp and release.
    PerceivedWorld* world = nullptr;
    if (auto w = worlds_.find(m.channel()); w != worlds_.end() && w->second.latest()->episode_id == m.episode_id())
      world = &w->second;
    auto it = running_.find(m.channel());
    const bool perceived = it != running_.end() && it->second.command.grounding() == "perception" &&
                           m.episode_id() == it->second.command.episode_id();
    std::optional<Unperceived> unseen;
    if (world) {
      Observation seen = obs;
      unseen = world->view(seen, perceived ? bound_entities(it->second.command) : std::vector<std::string>{});
      if (perceived) obs = std::move(seen);
    } else if (perceived) {
      unseen = Unperceived{"no scene estimate from the perception service for this episode", true};
    }
    if (it == running_.end()) return;
    Running& r = it->second;
    if (m.episode_id() != r.command.episode_id() || m.step() < r.command.start_step()) return;
    if (perceived && unseen) {
      // A missing or stale frame may still come: wait up to the limit without acting.
      const auto now = std::chrono::steady_clock::now();
      if (unseen->estimate_missing_or_stale) {
        if (!r.awaiting_frame_since) r.awaiting_frame_since = now;
        if (now - *r.awaiting_frame_since < limits_.wait) return;
      }
      const std::string why = "perception: " + unseen->reason +
                              (unseen->estimate_missing_or_stale
                                   ? "; waited " + std::to_string(limits_.wait.count()) + " ms for a fresh frame"
                                   : "");
      status(r, r.skill ? msg::STATE_FAILED : msg::STATE_REFUSED, why, m.step(), r.steps_used, r.stage);
      log_->info("channel={} command={} {}: {}", m.channel(), r.command.command_id(), r.skill ? "failed" : "refused", why);
      running_.erase(it);
      return;
    }
    r.awaiting_frame_since.reset();
    if (!r.skill && !begin(r, obs)) {
      running_.erase(it);
      return;
    }
    if (!r.skill) return;  // the start step's observation has not come yet
    const SkillStep s = r.skill->next(obs);
    if (s.status == SkillStatus::Running && r.steps_used >= r.command.budget_steps()) {
      status(r, msg::STATE_EXPIRED, "command budget of " + std::to_string(r.command.budget_steps()) + " steps spent",
             m.step(), r.steps_used, s.stage, s.progress);
      running_.erase(it);
      return;
    }
    if (s.status != SkillStatus::Running) {
      const bool ok = s.status == SkillStatus::Completed;
      status(r, ok ? msg::STATE_COMPLETED : msg::STATE_FAILED, s.reason, m.step(), r.steps_used, s.stage, s.progress);
      log_->info("channel={} command={} {} at step {} {}", m.channel(), r.command.command_id(),
                 ok ? "completed" : "failed", m.step(), s.reason);
      running_.erase(it);
      return;
    }
    msg::Action a;
    a.channel(m.channel());
    a.episode_id(m.episode_id());
    a.command_id(r.command.command_id());
    a.step(m.step());
    std::copy_n(s.action.begin(), 7, a.a().begin());
    action_.write(a);
    ++r.steps_used;
    if (s.stage != r.stage || m.step() % 10 == 0) {
      r.stage = s.stage;
      status(r, msg::STATE_RUNNING, "", m.step(), r.steps_used, s.stage, s.progress);
    }
  }

  /// From now on new commands are refused; running ones go on.
  void drain() { draining_ = true; }
  std::size_t running() const { return running_.size(); }

 private:
  void retry_awaiting(std::uint32_t channel) {
    const auto it = running_.find(channel);
    const auto o = last_obs_.find(channel);
    if (it != running_.end() && it->second.awaiting_frame_since && o != last_obs_.end()) {
      const msg::Observation m = o->second;
      handle(m);
    }
  }

  const Served* find(const std::string& instance) const {
    for (const auto& s : served_)
      if (s.descriptor.instance() == instance) return &s;
    return nullptr;
  }

  // Grounding at the capability on the command's first observation: θ, the skill's own check, start.
  bool begin(Running& r, const Observation& obs) {
    if (obs.step < r.command.start_step()) return true;  // wait for the start step's observation
    std::optional<std::string> why;
    std::unique_ptr<Skill> skill;
    try {
      skill = r.served->def.make(convert::from_msg(r.command.theta()));
    } catch (const std::invalid_argument& e) {
      why = std::string("malformed command: ") + e.what();
    }
    const Bindings args = bindings(r.command);
    if (!why) why = skill->check(args, obs, static_cast<int>(r.command.budget_steps()));
    if (why) {
      status(r, msg::STATE_REFUSED, *why, obs.step, 0);
      log_->info("channel={} command={} refused: {}", r.command.channel(), r.command.command_id(), *why);
      return false;
    }
    SkillContext ctx;
    if (auto k = keyframes_.find(r.command.channel()); k != keyframes_.end()) ctx.keyframes = k->second;
    skill->start(args, obs, ctx);
    r.skill = std::move(skill);
    status(r, msg::STATE_ACCEPTED, "", obs.step, 0);
    return true;
  }

  void cancel(std::map<std::uint32_t, Running>::iterator it, const std::string& why) {
    const auto o = last_obs_.find(it->first);
    status(it->second, msg::STATE_CANCELLED, why, o != last_obs_.end() ? o->second.step() : 0, it->second.steps_used);
    running_.erase(it);
  }

  // The tool pose when a command starts on a channel with an empty hand: a pose the arm reached safely.
  void record_keyframe(const msg::Command& c) {
    auto o = last_obs_.find(c.channel());
    if (o == last_obs_.end() || o->second.episode_id() != c.episode_id()) return;
    const msg::Observation& m = o->second;
    const Observation obs = convert::from_msg(m);
    if (obs.holding()) return;
    keyframes_[c.channel()].push_back({obs.step, obs.ee_p, obs.ee_q});
  }

  void status(const Running& r, msg::CommandState st, const std::string& reason, std::uint32_t step,
              std::uint32_t used, const std::string& stage = "", double progress = 0) {
    msg::CommandStatus s;
    s.channel(r.command.channel());
    s.episode_id(r.command.episode_id());
    s.command_id(r.command.command_id());
    s.instance(r.command.instance());
    s.state(st);
    s.reason(reason);
    s.step(step);
    s.steps_used(used);
    s.progress(progress);
    s.stage(stage);
    status_.write(s);
  }

  const std::vector<Served>& served_;
  PerceptionLimits limits_;
  std::shared_ptr<spdlog::logger> log_;
  dds::Writer<msg::ActionPubSubType> action_;
  dds::Writer<msg::CommandStatusPubSubType> status_;
  std::map<std::uint32_t, Running> running_;
  std::map<std::uint32_t, msg::Observation> last_obs_;
  std::map<std::uint32_t, std::vector<Keyframe>> keyframes_;
  std::map<std::uint32_t, PerceivedWorld> worlds_;  ///< per channel: its current episode's perceived world
  bool draining_ = false;
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
  return run_service(*log, [&] {
    char host[256] = "";
    gethostname(host, sizeof host - 1);
    std::vector<Served> served;
    for (const auto& def : make()) {
      std::filesystem::path file = default_descriptor_file(def.name);
      for (const auto& l : libraries)
        if (ConfigNode::load_file(l).get<std::string>("capability") == def.name) file = l;
      const std::string instance = def.name + "@" + std::string(host) + ":" + std::to_string(getpid());
      served.push_back({def, announcement(load_descriptor(file, def), instance)});
    }
    dds::Participant participant(service);
    EventQueue<Event> queue;
    Node node(participant, served, deployment_perception_limits(), log);  // θ arrives with each command
    dds::Reader<msg::CommandPubSubType> cmd(participant, topics::kCommand, dds::Qos::Command,
        {[&](const msg::Command& m, const auto&) { queue.push(m); }, {}, {}});
    dds::Reader<msg::ObservationPubSubType> obs(participant, topics::kObservation, dds::Qos::Observation,
        {[&](const msg::Observation& m, const auto&) { queue.push(m); }, {}, {}});
    dds::Reader<msg::SceneEstimatePubSubType> scene(participant, topics::kSceneEstimate, dds::Qos::Observation,
        {[&](const msg::SceneEstimate& m, const auto&) { queue.push(m); }, {}, {}});
    dds::Writer<msg::CapabilityAnnouncePubSubType> announce(participant, topics::kAnnounce, dds::Qos::Announce);
    for (const auto& s : served) {
      announce.write(s.descriptor);
      log->info("instance={} cost_steps={} announced", s.descriptor.instance(), s.descriptor.cost_steps());
    }
    const dds::Heartbeat alive([&announce] { announce.assert_liveliness(); },
                               std::chrono::milliseconds(static_cast<int>(dds::kLivelinessLeaseSec * 1000 / 4)));
    while (!shutdown_requested()) {
      if (auto e = queue.pop(std::chrono::milliseconds(50))) std::visit([&](auto& ev) { node.handle(ev); }, *e);
      node.tick();
    }
    node.drain();
    log->info("family={} draining: {} command(s) running", family, node.running());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(drain_timeout_s);
    while (node.running() > 0 && std::chrono::steady_clock::now() < deadline) {
      if (auto e = queue.pop(std::chrono::milliseconds(50))) std::visit([&](auto& ev) { node.handle(ev); }, *e);
      node.tick();
    }
    if (node.running() > 0) log->warn("family={} drain timed out with {} command(s) running", family, node.running());
  });
}

}  // namespace dh::cap
