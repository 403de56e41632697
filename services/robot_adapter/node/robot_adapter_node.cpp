// dh_robot_adapter: one Universal Robots arm over RTDE behind the robot seam, as one channel. The only
// process that may move the arm.
//
// Reads   rt/dh/episode/request (Episode)   start an episode on the arm's channel (the arm stays where it is)
//         rt/dh/action          (Action)    one 7-d action per step, lock-step
//         rt/dh/lease           (Lease, deadline 1 s) the governor's grant for the running command
//         rt/dh/episode/result  (Episode)   the channel goes idle, the arm stops
// Writes  rt/dh/observation     (Observation) at the start (step 0) and after every applied action: joints,
//                                           tool pose and gripper from the controller's outputs
//         rt/dh/seam/event      (Status)    refused actions and the cell's corrections (envelope, workspace)
//         rt/dh/sim/channel     (Episode)   idle/running, with liveliness; last_error says why an episode
//                                           ended on the cell's side (a protective stop, the link lost)
// The seam (admission, holds, abandonment) is sim::SeamCore; the arm is rtde::RtdeCell (rtde_cell.hpp),
// which drives the controller through the dh_servo program (servo_program.hpp). A held action sends no
// target, so the program's watchdog stops the arm; so does a dead adapter.
// Parameters: --channel, --host, --rtde-port, --script-port, --base x,y,z,yaw (the arm's base in the
// world, m and rad), --workspace-min/--workspace-max (the box, world frame), --joint-speed (the envelope,
// rad/s), --output-hz, --lease-grace-ms, --abandon-after-s, --name, --entities FILE (the cell's fixtures,
// parts and regions, put in every observation; cell_entities.hpp), --gripper (the jaw's shape),
// --gripper-interface digital-output|robotiq-urcap and --gripper-port (the jaw's gap and contacts from a
// Robotiq gripper's URCap; robotiq_socket.hpp).
#include <chrono>
#include <optional>

#include "dh/common/config.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/rtde/adapter_ports.hpp"
#include "dh/rtde/cell_entities.hpp"
#include "dh/rtde/rtde_cell.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/seam_messages.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

class AdapterBinding;
using Context = dds::Context<AdapterBinding>;

class AdapterBinding {
 public:
  using Inputs = dds::Inputs<dds::In<port::EpisodeRequest>, dds::In<port::Action>,
                             dds::In<port::Lease, dds::kDeadline>, dds::In<port::EpisodeResult>>;
  using Outputs = dds::Outputs<port::Observation, port::Verdict, port::SeamEvent, port::ChannelStatus>;

  std::string name() const { return "dh_robot_adapter"; }
  std::string description() const { return "a Universal Robots arm over RTDE behind the robot seam"; }
  const Ports& ports() const { return rtde::adapter_ports(); }
  std::chrono::milliseconds wait() const { return std::chrono::milliseconds(20); }

  void options(CLI::App& app) {
    app.add_option("--channel", channel_, "the arm's channel id");
    app.add_option("--host", cell_.host, "the controller's address");
    app.add_option("--rtde-port", cell_.rtde_port, "RTDE (30004 on a UR controller)");
    app.add_option("--script-port", cell_.script_port, "the secondary interface (30002 on a UR controller)");
    base_option_ = app.add_option("--base", base_,
                                  "the arm's base in the world: x,y,z (m),yaw (rad) (or the --entities file's base)")
                        ->delimiter(',')
                        ->expected(4);
    app.add_option("--workspace-min", ws_min_, "the workspace box's low corner (world, m)")
        ->delimiter(',')
        ->expected(3);
    app.add_option("--workspace-max", ws_max_, "the workspace box's high corner (world, m)")
        ->delimiter(',')
        ->expected(3);
    app.add_option("--joint-speed", cell_.limits.joint_speed, "the joint-speed envelope (rad/s)")
        ->check(CLI::PositiveNumber);
    app.add_option("--output-hz", cell_.output_hz, "the RTDE output rate (Hz)")
        ->check(CLI::Range(50.0, 500.0));
    app.add_option(
           "--timeout-ms", timeout_ms_,
           "how long the controller may stay silent in an exchange before the link counts as lost (a UR "
           "streams every 2 to 20 ms; a test double on a loaded host may pause longer)")
        ->check(CLI::Range(10u, 10000u));
    app.add_option("--lease-grace-ms", grace_ms_,
                   "wall time an action of a command without a lease waits for one");
    app.add_option("--abandon-after-s", abandon_after_s_,
                   "end a running episode nothing has advanced for this long")
        ->check(CLI::PositiveNumber);
    app.add_option("--name", name_, "the adapter's name in channel announcements");
    app.add_option("--entities", entities_,
                   "the cell's fixtures, parts and regions (YAML, cell_entities.hpp)")
        ->check(CLI::ExistingFile);
    app.add_option("--gripper", gripper_,
                   "the jaw's shape the skills plan contact with (robot::Gripper, m): pads below the TCP, a pad's "
                   "half width, its thickness, the hand above the TCP (default the 2F-85's: 0.01875,0.011,0.008,0.1415)")
        ->delimiter(',')
        ->expected(4)
        ->check(CLI::PositiveNumber);
    app.add_option("--gripper-interface", gripper_interface_,
                   "how the jaw is driven and read: digital-output (tool output 0; it reports its command only) or "
                   "robotiq-urcap (a Robotiq gripper through its URCap's socket; it reports its gap and contacts)")
        ->check(CLI::IsMember({"digital-output", "robotiq-urcap"}));
    app.add_option("--gripper-port", cell_.gripper_port, "the Robotiq URCap's server (63352 on a UR controller)");
  }

  void parsed() {
    for (int i = 0; i < 3; ++i) {
      if (ws_min_[i] >= ws_max_[i])
        throw std::invalid_argument("--workspace-min must be below --workspace-max on every axis");
      cell_.limits.workspace_min[i] = ws_min_[i];
      cell_.limits.workspace_max[i] = ws_max_[i];
    }
    cell_.timeout = std::chrono::milliseconds(timeout_ms_);
    cell_.base_xyz = {base_[0], base_[1], base_[2]};
    cell_.base_yaw = base_[3];
    if (!gripper_.empty()) cell_.gripper = {gripper_[0], gripper_[1], gripper_[2], gripper_[3]};
    if (gripper_interface_ == "robotiq-urcap")
      cell_.gripper_interface = rtde::RtdeCellConfig::GripperInterface::RobotiqUrcap;
  }

  void configure(Context& ctx) {
    if (!entities_.empty()) {
      cell_.entities = rtde::load_cell_entities(entities_);
      // The calibration file's base; a --base that says otherwise is refused (which one is meant is unclear).
      if (const auto base = rtde::load_cell_base(entities_)) {
        const std::vector<double> file(base->begin(), base->end());
        if (base_option_->count() && base_ != file)
          throw ConfigError("--base and " + entities_ + "'s base differ: give one of them");
        cell_.base_xyz = {file[0], file[1], file[2]};
        cell_.base_yaw = file[3];
      }
    }
    core_.emplace(channel_, sim::SeamSettings{
                                std::chrono::milliseconds(grace_ms_), std::chrono::seconds(abandon_after_s_),
                                std::chrono::milliseconds(static_cast<int>(dds::kLeaseDeadlineSec * 1000))});
    arm_.emplace(cell_);
    // An adapter that cannot reach its arm does not come up: the error says what to check.
    arm_->connect();
    ctx.log.info("arm at {}:{} (script {}): program {} running, tool at {:.3f},{:.3f},{:.3f} (base frame)",
                 cell_.host, cell_.rtde_port, cell_.script_port, rtde::ServoProgram::kName,
                 arm_->state().tcp[0], arm_->state().tcp[1], arm_->state().tcp[2]);
  }

  void activate(Context& ctx) {
    announce(ctx, msg::CHANNEL_IDLE);
    ctx.log.info("adapter={} channel={} domain={} up", name_, channel_, dds::domain_id());
  }
  void shutdown() {
    if (arm_) arm_->stop();
  }
  void tick(Context& ctx) {
    if (core_) publish(ctx, core_->on_tick(Clock::now()));
  }

  void on(const dds::Sample<port::EpisodeRequest>& s, Context& ctx) {
    const msg::EpisodeRequest& r = s.msg;
    if (r.channel() != channel_ || r.episode_id() == core_->episode_id() || r.episode_id() == last_episode_)
      return;
    if (core_->running()) {
      ctx.log.warn("channel={} busy with episode={}; request {} ignored", channel_, core_->episode_id(),
                   r.episode_id());
      return;
    }
    sim::SeamEffects fx;
    try {
      if (!arm_->connected()) {
        ctx.log.info("channel={} reconnecting to the arm", channel_);
        arm_->connect();
      }
      // No oracle on a real cell: the seam's predicate is empty and gives no verdict.
      fx = core_->start(*arm_, r.episode_id(), r.budget_steps(), "", Clock::now());
    } catch (const std::exception& e) {
      ctx.log.error("channel={} episode={} cannot start: {}", channel_, r.episode_id(), e.what());
      finish(ctx, r.episode_id(), e.what());
      return;
    }
    ctx.log.info("channel={} episode={} suite={} task={} started", channel_, r.episode_id(), r.suite(),
                 r.task());
    announce(ctx, msg::CHANNEL_RUNNING);
    publish(ctx, fx);
  }
  void on(const dds::Sample<port::Lease>& s, Context& ctx) {
    if (s.msg.channel() != channel_) return;
    publish(ctx, core_->on_lease(sim::from_msg(s.msg), Clock::now()));
  }
  void on(const dds::DeadlineMissed<port::Lease>&, Context& ctx) {
    if (core_->on_lease_silent(Clock::now()))
      ctx.log.warn("channel={} lease writer missed its {} s deadline; actions are held and the arm stops",
                   channel_, dds::kLeaseDeadlineSec);
  }
  void on(const dds::Sample<port::Action>& s, Context& ctx) {
    if (s.msg.channel() != channel_) return;
    publish(ctx, core_->on_action(sim::from_msg(s.msg), Clock::now()));
  }
  void on(const dds::Sample<port::EpisodeResult>& s, Context& ctx) {
    const msg::EpisodeResult& r = s.msg;
    if (!core_->running() || r.episode_id() != core_->episode_id()) return;
    ctx.log.info("channel={} episode={} ended success={} steps={}", channel_, r.episode_id(), r.success(),
                 r.steps());
    finish(ctx, r.episode_id(), "");
  }

 private:
  void announce(Context& ctx, msg::ChannelState state) {
    msg::ChannelStatus st;
    st.channel(channel_);
    st.worker(name_);
    st.state(state);
    st.episode_id(core_->episode_id());
    st.last_episode_id(last_episode_);
    st.last_steps(last_steps_);
    st.last_goal_step(-1);  // no oracle
    st.last_error(last_error_);
    ctx.write<port::ChannelStatus>(st);
  }

  void publish(Context& ctx, const sim::SeamEffects& fx) {
    for (const auto& e : fx.events) {
      ctx.write<port::SeamEvent>(sim::to_msg(e, channel_, core_->episode_id()));
      // The seam's end is logged once, as the episode's end below.
      if (e.kind != SeamEventKind::Ended) ctx.log.info("channel={} step={} {}", channel_, e.step, e.reason);
    }
    if (fx.observation)
      ctx.write<port::Observation>(convert::to_msg(*fx.observation, channel_, core_->episode_id()));
    if (fx.ended) {
      ctx.log.error("channel={} episode={} {}", channel_, core_->episode_id(), *fx.ended);
      finish(ctx, core_->episode_id(), *fx.ended);
    }
  }

  /// The channel goes idle and the arm stops, reporting the episode (and why it could not go on).
  void finish(Context& ctx, const std::string& episode, const std::string& error) {
    arm_->stop();
    last_episode_ = episode;
    last_steps_ = core_->step();
    last_error_ = error;
    core_->end();
    announce(ctx, msg::CHANNEL_IDLE);
  }

  std::uint32_t channel_ = 0;
  std::string name_ = "robot_adapter", entities_, gripper_interface_ = "digital-output";
  rtde::RtdeCellConfig cell_;
  CLI::Option* base_option_ = nullptr;
  std::vector<double> base_{0, 0, 0, 0}, ws_min_{-1, -1, -1}, ws_max_{1, 1, 1};
  std::vector<double> gripper_;  ///< --gripper; empty: RtdeCellConfig's (the 2F-85's)
  unsigned grace_ms_ = 1000, abandon_after_s_ = 60;
  unsigned timeout_ms_ = static_cast<unsigned>(rtde::RtdeCellConfig{}.timeout.count());
  std::optional<sim::SeamCore> core_;
  std::optional<rtde::RtdeCell> arm_;
  std::string last_episode_, last_error_;
  std::uint32_t last_steps_ = 0;
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::AdapterBinding{}); }
