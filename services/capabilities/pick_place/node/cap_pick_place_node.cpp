// dh_cap_pick_place: the analytic pick-and-place capability as its own process.
//
// Writes  rt/dh/capability/announce (Announce: transient-local, liveliness AUTOMATIC, lease 1 s)
//         rt/dh/action          (Action)  one action per observation while a command runs
//         rt/dh/command/status  (Status)  accepted / refused(reason) / running / completed / failed(reason)
// Reads   rt/dh/command         (Command) START / CANCEL addressed to this instance
//         rt/dh/observation     (Observation)
// Parameters: --library FILE (default configs/library/pick_place.yaml), --instance NAME,
// --drain-timeout-s S. On SIGTERM/SIGINT the instance drains: it refuses new commands and finishes the
// ones running (at most S seconds), then exits — how `dh swap` replaces it without losing a command.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <map>
#include <variant>

#include "dh/cap/pick_place.hpp"
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
#include "dh/msg/robotPubSubTypes.h"

namespace dh {
namespace {

using Event = std::variant<msg::Command, msg::Observation>;

struct Running {
  msg::Command command;
  std::optional<cap::PickPlaceSkill> skill;  // set once the first observation arrived
  std::uint32_t steps_used = 0;
  std::string stage;
};

class Node {
 public:
  Node(dds::Participant& p, std::string instance, std::shared_ptr<spdlog::logger> log)
      : instance_(std::move(instance)), log_(std::move(log)),
        action_(p, topics::kAction, dds::Qos::Action),
        status_(p, topics::kCommandStatus, dds::Qos::Status) {}

  void handle(const msg::Command& c) {
    if (c.instance() != instance_) return;
    if (c.kind() == msg::COMMAND_CANCEL) {
      auto it = running_.find(c.channel());
      if (it != running_.end() && it->second.command.command_id() == c.command_id()) {
        status(it->second, msg::STATE_CANCELLED, "cancelled by the governor", c.start_step() + it->second.steps_used,
               it->second.steps_used);
        running_.erase(it);
      }
      return;
    }
    if (draining_) {
      Running r{c, std::nullopt, 0, "pending"};
      status(r, msg::STATE_REFUSED, "instance " + instance_ + " is draining (being replaced or stopped)",
             c.start_step(), 0);
      return;
    }
    running_[c.channel()] = Running{c, std::nullopt, 0, "pending"};
    if (auto o = last_obs_.find(c.channel()); o != last_obs_.end()) handle(o->second);
  }

  void handle(const msg::Observation& m) {
    last_obs_[m.channel()] = m;
    auto it = running_.find(m.channel());
    if (it == running_.end()) return;
    Running& r = it->second;
    if (m.episode_id() != r.command.episode_id() || m.step() < r.command.start_step()) return;
    const Observation obs = convert::from_msg(m);
    if (!r.skill) {
      if (m.step() != r.command.start_step()) return;
      std::string object, target;
      for (const auto& b : r.command.args()) (b.role() == "object" ? object : target) = b.entity();
      std::optional<std::string> why;
      cap::PickPlaceParams params;
      try {
        params = cap::PickPlaceParams::from_map(convert::from_msg(r.command.theta()));
      } catch (const std::invalid_argument& e) {
        why = std::string("malformed command: ") + e.what();
      }
      cap::PickPlaceSkill skill(params);
      if (!why) why = skill.check(object, target, obs, static_cast<int>(r.command.budget_steps()));
      if (why) {
        status(r, msg::STATE_REFUSED, *why, m.step(), 0);
        log_->info("channel={} command={} refused: {}", m.channel(), r.command.command_id(), *why);
        running_.erase(it);
        return;
      }
      skill.start(object, target, obs);
      r.skill = std::move(skill);
      status(r, msg::STATE_ACCEPTED, "", m.step(), 0);
    }
    if (r.steps_used >= r.command.budget_steps()) {
      status(r, msg::STATE_EXPIRED, "command budget of " + std::to_string(r.command.budget_steps()) + " steps spent",
             m.step(), r.steps_used);
      running_.erase(it);
      return;
    }
    const cap::SkillStep s = r.skill->next(obs);
    if (s.status != cap::SkillStatus::Running) {
      const bool ok = s.status == cap::SkillStatus::Completed;
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
  void status(const Running& r, msg::CommandState st, const std::string& reason, std::uint32_t step,
              std::uint32_t used, const std::string& stage = "", double progress = 0) {
    msg::CommandStatus s;
    s.channel(r.command.channel());
    s.episode_id(r.command.episode_id());
    s.command_id(r.command.command_id());
    s.instance(instance_);
    s.state(st);
    s.reason(reason);
    s.step(step);
    s.steps_used(used);
    s.progress(progress);
    s.stage(stage);
    status_.write(s);
  }

  std::string instance_;
  std::shared_ptr<spdlog::logger> log_;
  dds::Writer<msg::ActionPubSubType> action_;
  dds::Writer<msg::CommandStatusPubSubType> status_;
  std::map<std::uint32_t, Running> running_;
  std::map<std::uint32_t, msg::Observation> last_obs_;
  bool draining_ = false;
};

msg::CapabilityAnnounce load_descriptor(const std::filesystem::path& file, const std::string& instance) {
  const ConfigNode root = ConfigNode::load_file(file);
  msg::CapabilityAnnounce a;
  a.capability(root.get<std::string>("capability"));
  a.instance(instance);
  a.version(root.get<std::string>("version"));
  a.arguments(root.get<std::vector<std::string>>("arguments"));
  a.preconditions(root.get<std::vector<std::string>>("preconditions"));
  std::map<std::string, double> theta;
  const ConfigNode params = root.child("parameters");
  for (const auto& k : params.keys()) theta[k] = params.get<double>(k);
  try {
    a.cost_steps(static_cast<std::uint32_t>(cap::PickPlaceParams::from_map(theta).cost_steps()));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(file.string() + ": key 'parameters': " + e.what());
  }
  a.parameters(convert::to_msg(theta));
  a.started_ns(static_cast<unsigned long long>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count()));
  return a;
}

int run(int argc, char** argv) {
  CLI::App app{"dh_cap_pick_place: analytic pick-and-place capability"};
  std::string library, instance;
  unsigned drain_timeout_s = 30;
  app.add_option("--library", library, "capability descriptor YAML (default: configs/library/pick_place.yaml)");
  app.add_option("--drain-timeout-s", drain_timeout_s, "on a stop, how long running commands may take to finish");
  app.add_option("--instance", instance, "instance name (default: pick_place@<host>:<pid>)");
  CLI11_PARSE(app, argc, argv);
  auto log = make_logger("dh_cap_pick_place");
  return run_service(*log, [&] {
    if (library.empty()) library = (paths::config_dir() / "library" / "pick_place.yaml").string();
    if (instance.empty()) {
      char host[256] = "";
      gethostname(host, sizeof host - 1);
      instance = "pick_place@" + std::string(host) + ":" + std::to_string(getpid());
    }
    const msg::CapabilityAnnounce descriptor = load_descriptor(library, instance);
    dds::Participant participant("dh_cap_pick_place");
    EventQueue<Event> queue;
    Node node(participant, instance, log);  // θ arrives with each command
    dds::Reader<msg::CommandPubSubType> cmd(participant, topics::kCommand, dds::Qos::Command,
        {[&](const msg::Command& m, const auto&) { queue.push(m); }, {}, {}});
    dds::Reader<msg::ObservationPubSubType> obs(participant, topics::kObservation, dds::Qos::Observation,
        {[&](const msg::Observation& m, const auto&) { queue.push(m); }, {}, {}});
    dds::Writer<msg::CapabilityAnnouncePubSubType> announce(participant, topics::kAnnounce, dds::Qos::Announce);
    announce.write(descriptor);
    log->info("instance={} cost_steps={} announced", instance, descriptor.cost_steps());
    while (!shutdown_requested())
      if (auto e = queue.pop(std::chrono::milliseconds(50))) std::visit([&](auto& ev) { node.handle(ev); }, *e);
    node.drain();
    log->info("instance={} draining: {} command(s) running", instance, node.running());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(drain_timeout_s);
    while (node.running() > 0 && std::chrono::steady_clock::now() < deadline)
      if (auto e = queue.pop(std::chrono::milliseconds(50))) std::visit([&](auto& ev) { node.handle(ev); }, *e);
    if (node.running() > 0) log->warn("instance={} drain timed out with {} command(s) running", instance, node.running());
  });
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
