// dh_sim_worker: K MuJoCo workcells (channels) in one process; the robot seam for simulation.
//
// Reads   rt/dh/episode/request (Episode)   reset a channel to suite/task/seed
//         rt/dh/action          (Action)    one 7-d action per step, lock-step
//         rt/dh/lease           (Lease, deadline 1 s) the governor's grant for the running command
//         rt/dh/episode/result  (Episode)   the channel goes idle
// Writes  rt/dh/observation     (Observation) after reset (step 0) and after every applied action, for
//                                           the participant whose action it was (dds_addressee.hpp; every
//                                           reader under perception grounding); a command's start step
//                                           again, for every reader, when its first lease comes
//         rt/dh/verdict         (Verdict)   every change of the task predicate
//         rt/dh/seam/event      (Status)    rejected actions and safety corrections, with reasons
//         rt/dh/sim/channel     (Episode)   idle/running per channel, so clients find a free one
//         rt/dh/camera          (Camera)    with --cameras: each camera's RGB8 image at episode start and
//                                           every --camera-every steps, before that step's observation
//         rt/dh/camera/rgbd     (RgbdFrame) one frame per request below (and every --rgbd-every steps)
// Reads   rt/dh/camera/rgbd/request (RgbdRequest) for a channel of this worker and a camera of
//                                           configs/cameras.yaml: the channel renders that camera's
//                                           RGB-D frame of its current state (the last step observed; the
//                                           last episode's final state when idle) on its own thread, between
//                                           steps, and answers with the request's id. Nothing is rendered,
//                                           and no OpenGL context is made, until the first request.
// The seam itself (admission, holds, abandonment) is sim::SeamCore (seam_core.hpp); this file carries its
// events and effects over DDS, on the one DDS shell (dds_shell.hpp), and renders cameras. Each channel is
// one of the shell's lanes: its own queue and thread (the OpenGL context is per thread); the loop keeps the
// other workers' channels and refuses actions and leases for channels nobody serves.
// Parameters: --channels K, --first-channel C, --lease-grace-ms (how long an action of a command without a
// lease waits for one before it is refused), --abandon-after-s (a running episode that has had no applied
// action, lease or request for this long is abandoned: its governor is gone; the channel goes idle and
// says why), --name, --runs-dir (each episode's step log, for `dh replay`, goes to <runs>/evidence/
// <episode>.steps beside the governor's evidence; default DH_RUNS_DIR or ./runs), --cameras agentview,wrist
// (default none: nothing is rendered), --camera-every N (steps, default 5), --camera-size S (S x S pixels,
// default 224). Each channel renders on its own thread with its own OpenGL context (EGL surfaceless); without
// one the worker does not start.
// --rgbd-every N (steps, default 0 = only on request) also publishes every RGB-D camera's frame at
// episode start and every N steps, before that step's observation.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "dh/common/convert.hpp"
#include "dh/common/dds_addressee.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/cameraPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/rgbd_frame_msg.hpp"
#include "dh/sim/seam_core.hpp"
#include "dh/sim/seam_messages.hpp"
#include "dh/sim/workcell.hpp"
#include "dh/sim/workcell_cache.hpp"
#include "dh/sim/worker_ports.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

class WorkerBinding;
using Context = dds::Context<WorkerBinding>;

/// A channel's cameras: its own OpenGL context (made current on the channel's thread) and what to render.
struct Rendering {
  std::unique_ptr<sim::GlContext> gl;  ///< null: no cameras
  std::vector<std::string> cameras;
  unsigned every = 5;
  int size = sim::kDefaultCameraSize;
  const sim::CamerasConfig* rgbd = nullptr;  ///< RGB-D cameras added to every model (configs/cameras.yaml)
  unsigned rgbd_every = 0;                   ///< 0: RGB-D frames only on request
};

class Channel;

/// The worker on the one DDS shell: its channels are the shell's lanes; the loop itself keeps the other
/// workers' channels and refuses actions and leases for a channel nobody serves.
class WorkerBinding {
 public:
  using Inputs =
      dds::Inputs<dds::In<port::EpisodeRequest>, dds::In<port::Action>, dds::In<port::Lease, dds::kDeadline>,
                  dds::In<port::EpisodeResult>, dds::In<port::RgbdRequest>, dds::In<port::ChannelStatus, dds::kSkipOwn>>;
  using Outputs = dds::Outputs<port::Observation, port::Verdict, port::SeamEvent, port::ChannelStatus, port::Camera,
                               port::Rgbd>;
  using Lane = Channel;

  std::string name() const { return "dh_sim_worker"; }
  std::string description() const { return "MuJoCo workcell channels behind the robot seam"; }
  const Ports& ports() const { return sim::worker_ports(); }
  void options(CLI::App& app);
  void parsed();
  void configure(Context& ctx);
  void activate(Context& ctx);
  void shutdown();
  std::chrono::milliseconds wait() const { return std::chrono::milliseconds(20); }
  // A channel builds a scene's model on its own thread, between steps: the worker's liveliness waits that
  // long for it (the channel lease is 2 s).
  std::chrono::milliseconds loop_allowance() const { return std::chrono::milliseconds(1500); }

  unsigned lanes() const { return channels_; }
  Channel& lane(unsigned i) { return *chans_[i]; }
  // The listeners' routing reads only what configure fixed: this worker's channels and RGB-D cameras.
  std::optional<unsigned> lane_of(const msg::EpisodeRequest& m) const { return mine(m.channel()); }
  std::optional<unsigned> lane_of(const msg::Action& m) const { return mine(m.channel()); }
  std::optional<unsigned> lane_of(const msg::Lease& m) const { return mine(m.channel()); }
  std::optional<unsigned> lane_of(const msg::EpisodeResult& m) const { return mine(m.channel()); }
  // A camera this worker does not have may be a frames_player's to answer.
  std::optional<unsigned> lane_of(const msg::RgbdRequest& m) const {
    return rgbd_.has(m.camera()) ? mine(m.channel()) : std::nullopt;
  }

  // Channels every worker announces: other workers' actions and leases are theirs. For a channel nobody
  // serves they are garbage: refused and recorded on the seam topic by every worker.
  void on(const dds::Sample<port::ChannelStatus>& s, Context&) { known_.insert(s.msg.channel()); }
  void on(const dds::Sample<port::Action>& s, Context& ctx) {
    refuse_unknown(ctx, s.msg.channel(), s.msg.episode_id(), s.msg.step(), s.msg.command_id(), "action");
  }
  void on(const dds::Sample<port::Lease>& s, Context& ctx) {
    refuse_unknown(ctx, s.msg.channel(), s.msg.episode_id(), 0, s.msg.command_id(), "lease");
  }

 private:
  std::optional<unsigned> mine(std::uint32_t ch) const {
    return ch >= first_ && ch < first_ + channels_ ? std::optional<unsigned>(ch - first_) : std::nullopt;
  }
  void refuse_unknown(Context& ctx, std::uint32_t ch, const std::string& episode, std::uint32_t step,
                      const std::string& command, const char* what) {
    if (known_.count(ch)) return;
    const SeamEvent e{step, command, SeamEventKind::RejectedChannel,
                      std::string(what) + " for channel " + std::to_string(ch) + ", which no simulator worker serves",
                      episode};
    ctx.write<port::SeamEvent>(sim::to_msg(e, ch, episode));
    ctx.log.warn("worker={} rejected: {}", name_, e.reason);
  }

  unsigned channels_ = 1, first_ = 0, grace_ms_ = 1000, abandon_after_s_ = 60;
  std::string name_ = "sim_worker", runs_;
  std::vector<std::string> cameras_;
  unsigned camera_every_ = 5;
  int camera_size_ = sim::kDefaultCameraSize;
  unsigned rgbd_every_ = 0;
  std::map<std::string, SuiteDef> suites_;
  sim::CamerasConfig rgbd_;
  std::vector<std::unique_ptr<Channel>> chans_;
  std::set<std::uint32_t> known_;  ///< channels other workers announce
};

/// One channel: a workcell behind its seam core, and its cameras. A lane of the shell: every handler runs on
/// the channel's own thread.
class Channel {
 public:
  Channel(std::uint32_t id, std::string worker, const std::map<std::string, SuiteDef>& suites, Context& ctx,
          sim::SeamSettings seam, std::filesystem::path runs, Rendering rendering)
      : id_(id), worker_(std::move(worker)), suites_(suites), ctx_(ctx), log_(ctx.log), core_(id, seam),
        runs_(std::move(runs)), render_(std::move(rendering)), cells_([this](sim::SceneSpec& spec) {
          if (render_.rgbd) spec.cameras = render_.rgbd->for_scene(spec.name);
        }) {}

  void enter(Context&) {
    if (render_.gl) {
      try {
        render_.gl->make_current();
      } catch (const std::exception& e) {
        throw std::runtime_error("channel " + std::to_string(id_) + " cannot render its cameras: " + e.what());
      }
    }
    announce(msg::CHANNEL_IDLE);
  }
  void leave(Context&) {
    if (rgbd_frames_)
      log_.info("channel={} {} RGB-D frames, {:.1f} ms each to render, {:.1f} ms to publish", id_, rgbd_frames_,
                1e3 * rgbd_render_s_ / rgbd_frames_, 1e3 * rgbd_publish_s_ / rgbd_frames_);
    rig_.reset();  // GPU state goes on this thread, while its context is current
    rgbd_rigs_.clear();
    if (render_.gl) render_.gl->release();
    if (rgbd_gl_) rgbd_gl_->release();
  }
  void tick(Context&) { publish(core_.on_tick(Clock::now())); }

  void on(const dds::Sample<port::EpisodeRequest>& s, Context&) { handle(s.msg); }
  /// One RGB-D frame of the state the channel shows now, answering the request (an error frame when it cannot).
  void on(const dds::Sample<port::RgbdRequest>& s, Context&) {
    log_.debug("channel={} RGB-D request {} for camera {}", id_, s.msg.request_id(), s.msg.camera());
    publish_rgbd(s.msg.camera(), s.msg.request_id());
  }
  void on(const dds::Sample<port::Lease>& s, Context&) {
    publish(core_.on_lease(sim::from_msg(s.msg), Clock::now()));
  }
  // The deadline event names no channel we can use (every lane gets it), so the core checks its own lease's age.
  void on(const dds::DeadlineMissed<port::Lease>&, Context&) {
    if (core_.on_lease_silent(Clock::now()))
      log_.warn("channel={} lease writer missed its {} s deadline; actions are held until it is heard", id_,
                dds::kLeaseDeadlineSec);
  }
  void on(const dds::Sample<port::Action>& s, Context&) {
    sim::ActionIn a = sim::from_msg(s.msg);
    a.from = dds::participant_address(s.writer);
    publish(core_.on_action(a, Clock::now()));
  }
  void on(const dds::Sample<port::EpisodeResult>& s, Context&) {
    const msg::EpisodeResult& r = s.msg;
    if (!core_.running() || r.episode_id() != core_.episode_id()) return;
    log_.info("channel={} episode={} ended success={} steps={} physics_s={:.3f} stragglers={}", id_, r.episode_id(),
              r.success(), r.steps(), reset_s_ + core_.physics_s(), core_.stragglers());
    if (images_)
      log_.info("channel={} episode={} {} camera images, {:.1f} ms each (render and publish)", id_, r.episode_id(),
                images_, 1e3 * render_s_ / images_);
    finish(r.episode_id(), "");
  }

 private:
  void announce(msg::ChannelState s) {
    msg::ChannelStatus st;
    st.channel(id_);
    st.worker(worker_);
    st.state(s);
    st.episode_id(core_.episode_id());
    st.last_episode_id(last_episode_);
    st.last_steps(last_steps_);
    st.last_physics_s(last_physics_s_);
    st.last_goal_step(last_goal_step_);
    st.last_goal_at_end(last_goal_at_end_);
    st.last_error(last_error_);
    ctx_.write<port::ChannelStatus>(st);
  }

  void handle(const msg::EpisodeRequest& r) {
    if (r.episode_id() == core_.episode_id() || r.episode_id() == last_episode_) return;  // transient-local redelivery
    if (core_.running()) {
      // One client's request must not preempt another's episode; the governor answers it "rejected".
      log_.warn("channel={} busy with episode={}; request {} ignored", id_, core_.episode_id(), r.episode_id());
      return;
    }
    sim::Workcell* reset = nullptr;
    std::string predicate;
    try {
      const TaskDef& task = find_task(suites_, r.suite(), r.task());
      const auto b0 = Clock::now();
      const auto got = cells_.get(task, r.seed(), r.robot());
      if (got.compiled) {
        // The lane does not turn while a model is built: its time is logged beside the loop allowance.
        log_.info("channel={} model for {} built in {:.0f} ms", id_, sim::task_scene_key(task, r.seed(), r.robot()),
                  std::chrono::duration<double, std::milli>(Clock::now() - b0).count());
        // An object cell's new model may sit where the freed one was: nothing may keep the old pointer.
        rig_.reset();
        rgbd_rigs_.clear();
        shown_ = nullptr;
      }
      const auto t0 = Clock::now();
      got.cell.reset(r.seed(), task.goal);
      reset_s_ = std::chrono::duration<double>(Clock::now() - t0).count();
      reset = &got.cell;
      shown_ = reset;
      std::string varied;
      for (const auto& e : reset->scene().entities)
        if (!e.variation.empty()) varied += (varied.empty() ? "" : "; ") + e.name + " " + e.variation;
      if (!varied.empty()) log_.info("channel={} episode={} objects: {}", id_, r.episode_id(), varied);
      predicate = goal_text(task.goal);
      if (render_.gl && (!rig_ || rig_->model() != reset->model())) {
        rig_.reset();  // one scene's GPU state at a time (a few MB each)
        const auto r0 = Clock::now();
        rig_ = std::make_unique<sim::CameraRig>(*reset, render_.cameras, render_.size, render_.size);
        log_.debug("channel={} camera rig for {} in {:.1f} ms", id_, sim::task_scene_key(task, r.seed(), r.robot()),
                    std::chrono::duration<double, std::milli>(Clock::now() - r0).count());
      }
    } catch (const std::exception& e) {
      log_.error("channel={} episode={} cannot start: {}", id_, r.episode_id(), e.what());
      finish(r.episode_id(), e.what());
      return;
    }
    render_s_ = 0;
    images_ = 0;
    // Under perception grounding every capability host's perceived world follows each step (grasps and
    // releases), so every step goes to every reader.
    to_everyone_ = r.grounding() != "state";
    sim::SeamEffects fx;
    try {
      fx = core_.start(*reset, r.episode_id(), r.budget_steps(), predicate, Clock::now(),
                       paths::evidence_file(runs_, r.episode_id(), ".steps"));
    } catch (const std::exception& e) {
      log_.error("channel={} episode={} cannot start: {}", id_, r.episode_id(), e.what());
      finish(r.episode_id(), e.what());
      return;
    }
    log_.info("channel={} episode={} suite={} task={} seed={}{} started", id_, r.episode_id(), r.suite(), r.task(),
               r.seed(), r.robot().empty() ? "" : " robot=" + r.robot());
    announce(msg::CHANNEL_RUNNING);
    publish(fx);
  }

  /// Carries the core's effects out: refusals and corrections, the verdict, images, then the observation.
  void publish(const sim::SeamEffects& fx) {
    for (const auto& e : fx.events) {
      ctx_.write<port::SeamEvent>(sim::to_msg(e, id_, core_.episode_id()));
      if (is_refusal(e.kind)) log_.info("channel={} step={} action refused: {}", id_, e.step, e.reason);
    }
    if (fx.verdict) {
      msg::Verdict v;
      v.channel(id_);
      v.episode_id(core_.episode_id());
      v.step(fx.verdict->step);
      v.predicate(fx.verdict->predicate);
      v.value(fx.verdict->value);
      ctx_.write<port::Verdict>(v);
    }
    if (fx.again) {
      msg::Observation o = convert::to_msg(*fx.again, id_, core_.episode_id());
      o.again(true);
      ctx_.write<port::Observation>(o);
    }
    if (fx.observation) {
      if (rig_ && core_.step() % render_.every == 0) publish_images();
      if (render_.rgbd_every && core_.step() % render_.rgbd_every == 0)
        for (const auto& c : render_.rgbd->cameras) publish_rgbd(c.camera.name, "");
      msg::Observation o = convert::to_msg(*fx.observation, id_, core_.episode_id());
      if (!to_everyone_) o.addressee(fx.to);
      ctx_.write<port::Observation>(o);
    }
    if (fx.ended) {
      log_.error("channel={} episode={} {}", id_, core_.episode_id(), *fx.ended);
      finish(core_.episode_id(), *fx.ended);
    }
  }

  /// The channel goes idle, reporting the episode it ran (or could not run, and why).
  void finish(const std::string& episode, const std::string& error) {
    last_episode_ = episode;
    last_steps_ = error.empty() ? core_.step() : 0;
    last_physics_s_ = error.empty() ? reset_s_ + core_.physics_s() : 0;
    const auto goal = core_.goal_step();
    last_goal_step_ = error.empty() && goal ? static_cast<std::int32_t>(*goal) : -1;
    last_goal_at_end_ = error.empty() && core_.observation().goal_holds;
    last_error_ = error;
    core_.end();
    announce(msg::CHANNEL_IDLE);
  }

  /// Every camera's image of the current state, before the observation of the same step.
  void publish_images() {
    const auto t0 = Clock::now();
    for (std::size_t i = 0; i < rig_->cameras().size(); ++i) {
      rig_->render(i, image_);
      image_msg_.channel(id_);
      image_msg_.camera(rig_->cameras()[i]);
      image_msg_.episode_id(core_.episode_id());
      image_msg_.step(core_.step());
      image_msg_.width(static_cast<std::uint32_t>(image_.width));
      image_msg_.height(static_cast<std::uint32_t>(image_.height));
      image_msg_.encoding("rgb8");
      image_msg_.data().swap(image_.rgb);  // no copy; render() refills the other buffer next time
      ctx_.write<port::Camera>(image_msg_);
      ++images_;
    }
    render_s_ += std::chrono::duration<double>(Clock::now() - t0).count();
  }

  /// The channel's OpenGL context, current on this thread: --cameras' own, or one made at the first
  /// RGB-D frame. Throws RenderError when none can be made.
  void ensure_gl() {
    if (render_.gl || rgbd_gl_) return;
    if (!rgbd_gl_error_.empty()) throw sim::RenderError(rgbd_gl_error_);  // tried once, do not retry
    try {
      auto gl = std::make_unique<sim::GlContext>();
      gl->make_current();
      log_.info("channel={} OpenGL context for RGB-D frames: {}", id_, gl->description());
      rgbd_gl_ = std::move(gl);
    } catch (const std::exception& e) {
      rgbd_gl_error_ = e.what();
      throw;
    }
  }

  /// Renders `camera`'s RGB-D frame of the state shown and publishes it with `request_id`.
  void publish_rgbd(const std::string& camera, const std::string& request_id) {
    rgbd_msg_.channel(id_);
    rgbd_msg_.camera(camera);
    rgbd_msg_.source("sim_worker " + worker_);
    rgbd_msg_.episode_id(core_.running() ? core_.episode_id() : std::string());
    rgbd_msg_.step(core_.step());
    rgbd_msg_.request_id(request_id);
    rgbd_msg_.error("");
    rgbd_msg_.has_pose(false);
    rgbd_msg_.position({0, 0, 0});
    rgbd_msg_.orientation({1, 0, 0, 0});
    rgbd_msg_.fx(0);
    rgbd_msg_.fy(0);
    rgbd_msg_.cx(0);
    rgbd_msg_.cy(0);
    rgbd_msg_.stamp_s(0);
    const auto t0 = Clock::now();
    try {
      if (!shown_)
        throw std::runtime_error("channel " + std::to_string(id_) + " has run no episode yet: no state to render");
      ensure_gl();
      auto& rig = rgbd_rigs_[camera];
      if (!rig || rig->model() != shown_->model()) {
        const auto specs = render_.rgbd->for_scene(shown_->scene().name);
        const auto spec = std::find_if(specs.begin(), specs.end(), [&](const auto& c) { return c.name == camera; });
        if (spec == specs.end()) throw std::runtime_error("no RGB-D camera '" + camera + "' in configs/cameras.yaml");
        rig.reset();
        rig = std::make_unique<sim::CameraRig>(*shown_, std::vector<std::string>{camera}, spec->width, spec->height);
      }
      rig->render(0, rgbd_image_, rgbd_depth_);
      const sim::Pinhole K = sim::camera_pinhole(shown_->model(), camera, rig->width(), rig->height());
      const sim::CameraPose pose = sim::camera_pose(shown_->model(), shown_->data(), camera);
      rgbd_msg_.stamp_s(shown_->data()->time);
      sim::set_camera(rgbd_msg_, K, pose);
      rgbd_msg_.rgb().swap(rgbd_image_.rgb);  // no copy; render() refills the other buffer next time
      auto& bytes = rgbd_msg_.depth();
      bytes.resize(2 * rgbd_depth_.size());
      for (std::size_t i = 0; i < rgbd_depth_.size(); ++i) {  // little-endian whatever the host
        bytes[2 * i] = static_cast<std::uint8_t>(rgbd_depth_[i] & 0xFF);
        bytes[2 * i + 1] = static_cast<std::uint8_t>(rgbd_depth_[i] >> 8);
      }
    } catch (const std::exception& e) {
      rgbd_msg_.error(e.what());
      rgbd_msg_.width(0);
      rgbd_msg_.height(0);
      rgbd_msg_.rgb().clear();
      rgbd_msg_.depth().clear();
      log_.error("channel={} RGB-D frame of camera {} (request '{}') cannot be made: {}", id_, camera, request_id,
                  e.what());
    }
    const auto t1 = Clock::now();
    ctx_.write<port::Rgbd>(rgbd_msg_);
    const auto t2 = Clock::now();
    if (rgbd_msg_.error().empty()) {
      ++rgbd_frames_;
      rgbd_render_s_ += std::chrono::duration<double>(t1 - t0).count();
      rgbd_publish_s_ += std::chrono::duration<double>(t2 - t1).count();
      log_.debug("channel={} RGB-D frame {} step={} rendered in {:.1f} ms, published in {:.1f} ms", id_, request_id,
                  core_.step(), std::chrono::duration<double, std::milli>(t1 - t0).count(),
                  std::chrono::duration<double, std::milli>(t2 - t1).count());
    }
  }

  std::uint32_t id_;
  std::string worker_;
  const std::map<std::string, SuiteDef>& suites_;
  Context& ctx_;
  spdlog::logger& log_;
  sim::SeamCore core_;
  std::filesystem::path runs_;  ///< step logs go to runs_/evidence, beside the governor's evidence
  Rendering render_;
  std::unique_ptr<sim::CameraRig> rig_;  ///< the current cell's cameras (with --cameras)
  sim::Image image_;
  msg::CameraImage image_msg_;
  const sim::Workcell* shown_ = nullptr;  ///< the cell whose state RGB-D frames show (kept when idle)
  std::unique_ptr<sim::GlContext> rgbd_gl_;  ///< made at the first RGB-D frame when there is no --cameras context
  std::string rgbd_gl_error_;
  std::map<std::string, std::unique_ptr<sim::CameraRig>> rgbd_rigs_;  ///< per RGB-D camera, for shown_'s model
  sim::Image rgbd_image_;
  std::vector<std::uint16_t> rgbd_depth_;
  msg::RgbdFrame rgbd_msg_;
  std::uint64_t rgbd_frames_ = 0;
  double rgbd_render_s_ = 0, rgbd_publish_s_ = 0;
  double render_s_ = 0;  ///< wall time rendering and publishing images in the running episode
  std::uint32_t images_ = 0;
  sim::WorkcellCache cells_;
  std::string last_episode_, last_error_;
  bool to_everyone_ = true;                  ///< the running episode's steps go to every reader (see handle)
  double reset_s_ = 0, last_physics_s_ = 0;  ///< wall time inside MuJoCo: the reset, the last episode in all
  std::uint32_t last_steps_ = 0;
  std::int32_t last_goal_step_ = -1;  ///< the simulator's own verdict on the last episode (-1: goal never held)
  bool last_goal_at_end_ = false;
};


void WorkerBinding::options(CLI::App& app) {
  app.add_option("--channels", channels_, "number of channels (workcells) in this process")->check(CLI::Range(1, 64));
  app.add_option("--first-channel", first_, "id of the first channel");
  app.add_option("--lease-grace-ms", grace_ms_, "wall time an action of a command without a lease waits for one");
  app.add_option("--abandon-after-s", abandon_after_s_, "end a running episode nothing has advanced for this long")
      ->check(CLI::PositiveNumber);
  app.add_option("--name", name_, "worker name in channel announcements");
  app.add_option("--runs-dir", runs_, "where step logs go, under evidence/ (default: DH_RUNS_DIR or ./runs)");
  app.add_option("--cameras", cameras_, "cameras to publish on rt/dh/camera: agentview,wrist (default: none)")
      ->delimiter(',')
      ->check(CLI::IsMember(sim::workcell_cameras()));
  app.add_option("--camera-every", camera_every_, "images every N control steps and at episode start")
      ->check(CLI::Range(1u, 1000000u));
  app.add_option("--camera-size", camera_size_, "image width and height (px)")->check(CLI::Range(16, 480));
  app.add_option("--rgbd-every", rgbd_every_,
                 "also publish every RGB-D camera's frame at episode start and every N steps (0: only on request)");
}

void WorkerBinding::parsed() {
  std::sort(cameras_.begin(), cameras_.end());
  cameras_.erase(std::unique(cameras_.begin(), cameras_.end()), cameras_.end());
}

void WorkerBinding::configure(Context& ctx) {
  const std::filesystem::path runs_dir =
      std::filesystem::absolute(runs_.empty() ? paths::runs_dir() : std::filesystem::path(runs_));
  suites_ = load_suites(paths::config_dir());
  // RGB-D cameras (configs/cameras.yaml) go into every model; they render only when asked.
  const auto rgbd_file = paths::config_dir() / "cameras.yaml";
  if (std::filesystem::exists(rgbd_file)) rgbd_ = sim::load_cameras_config(rgbd_file);
  else ctx.log.warn("{} not found: no RGB-D cameras, requests on {} go unanswered", rgbd_file.string(), topics::kRgbdRequest);
  if (rgbd_every_ && rgbd_.cameras.empty())
    throw std::runtime_error("--rgbd-every " + std::to_string(rgbd_every_) + " but " + rgbd_file.string() +
                             " names no RGB-D camera");
  // Rendering is checked before anything starts, so a machine without it fails here, not mid-episode.
  std::vector<std::unique_ptr<sim::GlContext>> contexts;
  if (!cameras_.empty()) {
    std::string list;
    for (const auto& c : cameras_) list += (list.empty() ? "" : ",") + c;
    try {
      for (unsigned i = 0; i < channels_; ++i) contexts.push_back(std::make_unique<sim::GlContext>());
      const std::string renderer = sim::check_rendering(*contexts.front(), camera_size_, camera_size_);
      ctx.log.info("cameras {} at {}x{} px every {} steps on {}; {}", list, camera_size_, camera_size_, camera_every_,
                   topics::kCamera, renderer);
    } catch (const sim::RenderError& e) {
      throw std::runtime_error("--cameras " + list + " cannot be rendered: " + e.what());
    }
  }
  if (rgbd_every_) {  // periodic frames: check now, as for --cameras (on request: checked at the first one)
    try {
      sim::GlContext gl;
      ctx.log.info("RGB-D frames every {} steps on {}; {}", rgbd_every_, topics::kRgbd, sim::check_rendering(gl, 64, 64));
    } catch (const sim::RenderError& e) {
      throw std::runtime_error("--rgbd-every " + std::to_string(rgbd_every_) + " cannot be rendered: " + e.what());
    }
  }
  const sim::SeamSettings seam{std::chrono::milliseconds(grace_ms_), std::chrono::seconds(abandon_after_s_),
                               std::chrono::milliseconds(static_cast<int>(dds::kLeaseDeadlineSec * 1000))};
  for (unsigned i = 0; i < channels_; ++i) {
    Rendering rendering{contexts.empty() ? nullptr : std::move(contexts[i]), cameras_, camera_every_, camera_size_,
                        &rgbd_, rgbd_every_};
    chans_.push_back(std::make_unique<Channel>(first_ + i, name_, suites_, ctx, seam, runs_dir, std::move(rendering)));
  }
}

void WorkerBinding::activate(Context& ctx) {
  std::string rgbd_names;
  for (const auto& c : rgbd_.cameras) rgbd_names += (rgbd_names.empty() ? "" : ",") + c.camera.name;
  ctx.log.info("worker={} channels={}..{} domain={} up; RGB-D cameras on request: {}", name_, first_,
               first_ + channels_ - 1, dds::domain_id(), rgbd_names.empty() ? "none" : rgbd_names);
}

void WorkerBinding::shutdown() { chans_.clear(); }

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::WorkerBinding{}); }
