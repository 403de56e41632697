// perception: scene estimates from RGB-D frames, for arms that ground from perception.
// Reads   rt/dh/episode/request (Episode)      which scene a channel runs: the free objects to look for,
//                                              for episodes whose request says grounding "perception"
//         rt/dh/episode/result  (Episode)      the channel's episode is over
//         rt/dh/observation     (Observation)  when to look: step 0, then every --every-steps
//         rt/dh/camera/rgbd     (Rgbd)         the frames it asked for
// Writes  rt/dh/camera/rgbd/request (RgbdRequest)  one frame of the channel's current state
//         rt/dh/perception/scene    (Observation)  one SceneEstimate per frame: looked for, seen, latency
// Parameters: --camera (workcell), --every-steps (10), --backend colour|http, --segment-url,
// --segment-timeout-s, --frame-timeout-ms (a request unanswered this long is asked again), --table-z
// (the support surface's height, 0 in the workcell) or --search-support-plane.
#include <CLI/CLI.hpp>

#include <chrono>
#include <map>
#include <memory>
#include <optional>

#include "dh/common/config.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/msg/cameraPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/perceptionPubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/perception/colour_segmenter.hpp"
#include "dh/perception/estimate.hpp"
#include "dh/perception/http_segmenter.hpp"
#include "dh/perception/ports.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/scene.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;
using dds::In;
using dds::Sample;

struct ChannelState {
  std::string episode_id;
  std::vector<perception::LookFor> objects;
  std::vector<perception::EntityAppearance> looked_for;
  std::optional<std::uint32_t> last_step;  ///< the step of the last frame asked for
  std::string pending;                     ///< request id awaiting its frame
  Clock::time_point asked_at;
};

/// The frame as the perception library takes it (copies the pixels).
perception::RgbdFrame to_frame(const msg::RgbdFrame& m) {
  perception::RgbdFrame f;
  f.K = {m.fx(), m.fy(), m.cx(), m.cy(), static_cast<int>(m.width()), static_cast<int>(m.height())};
  const auto& q = m.orientation();
  f.world_from_camera = Eigen::Translation3d(m.position()[0], m.position()[1], m.position()[2]) *
                        Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  f.rgb = cv::Mat(f.K.height, f.K.width, CV_8UC3, const_cast<unsigned char*>(m.rgb().data())).clone();
  f.depth = cv::Mat(f.K.height, f.K.width, CV_16UC1, const_cast<unsigned char*>(m.depth().data())).clone();
  f.stamp_s = m.stamp_s();
  return f;
}

/// Run by the one DDS shell (dds_shell.hpp). The channel bookkeeping is still here, not in a DDS-free core.
class PerceptionBinding {
 public:
  using Inputs = dds::Inputs<In<port::EpisodeRequest>, In<port::EpisodeResult>, In<port::Observation>, In<port::Rgbd>>;
  using Outputs = dds::Outputs<port::RgbdRequest, port::SceneEstimate>;
  using Context = dds::Context<PerceptionBinding>;

  std::string name() const { return "dh_perception"; }
  std::string description() const { return "scene estimates from RGB-D frames (OpenCV masks, PCL boxes)"; }
  const Ports& ports() const { return perception::ports(); }
  void options(CLI::App& app) {
    app.add_option("--camera", camera_, "camera to ask for (configs/cameras.yaml, or what frames_player plays as)");
    app.add_option("--every-steps", every_, "ask for a frame every N control steps (and at step 0)")
        ->check(CLI::PositiveNumber);
    app.add_option("--backend", backend_, "colour (from the scene description) | http (a SAM-style server)")
        ->check(CLI::IsMember({"colour", "http"}));
    app.add_option("--segment-url", url_, "http backend: the server's endpoint, e.g. http://127.0.0.1:8765/segment");
    app.add_option("--segment-timeout-s", segment_timeout_s_, "http backend: whole-request timeout");
    app.add_option("--frame-timeout-ms", frame_timeout_ms_, "a frame not answered this long is asked for again");
    app.add_option("--table-z", table_z_, "height of the table top in the world (m; the workcell's is 0)");
    app.add_flag("--search-support-plane", search_plane_,
                 "the table height is not known: find it in each mask (RANSAC)");
  }
  void configure(Context&) {
    if (backend_ == "http") {
      if (url_.empty()) throw ConfigError("--backend http needs --segment-url (the segmentation server's endpoint)");
      perception::HttpSegmenterConfig c;
      c.url = url_;
      c.timeout_s = segment_timeout_s_;
      segmenter_ = std::make_unique<perception::HttpSegmenter>(c);
    } else {
      segmenter_ = std::make_unique<perception::ColourSegmenter>();
    }
    if (!search_plane_) cloud_.support_z = table_z_;
    suites_ = load_suites(paths::config_dir());
  }
  void activate(Context& ctx) {
    ctx.log.info("backend={} camera={} every {} steps; domain={} up", backend_, camera_, every_, dds::domain_id());
  }
  void on(const Sample<port::EpisodeRequest>& s, Context& ctx) { handle(s.msg, ctx); }
  void on(const Sample<port::EpisodeResult>& s, Context&) {
    const auto& r = s.msg;
    auto it = channels_.find(r.channel());
    if (it != channels_.end() && it->second.episode_id == r.episode_id()) channels_.erase(it);
  }
  void on(const Sample<port::Observation>& s, Context& ctx) {
    const auto& o = s.msg;
    last_seen_[o.channel()] = {o.episode_id(), o.step()};
    auto it = channels_.find(o.channel());
    if (it == channels_.end() || it->second.episode_id != o.episode_id()) return;
    auto& ch = it->second;
    if (!ch.pending.empty() || (ch.last_step && o.step() < *ch.last_step + every_)) return;
    ask(ctx, o.channel(), ch, o.step());
  }
  void on(const Sample<port::Rgbd>& s, Context& ctx) { handle(s.msg, ctx); }
  /// A request unanswered for the frame timeout is asked again (the robot may be waiting for it).
  void tick(Context& ctx) {
    for (auto& [id, ch] : channels_)
      if (!ch.pending.empty() && Clock::now() - ch.asked_at >= std::chrono::milliseconds(frame_timeout_ms_)) {
        ctx.log.warn("channel={} frame {} not answered in time; asking again", id, ch.pending);
        ask(ctx, id, ch, ch.last_step.value_or(0));
      }
  }

 private:
  void handle(const msg::EpisodeRequest& r, Context& ctx) {
    // Rendering costs the simulator time: only episodes grounded in perception are looked at.
    if (r.grounding() != "perception") {
      channels_.erase(r.channel());
      return;
    }
    auto& ch = channels_[r.channel()];
    if (ch.episode_id == r.episode_id()) return;
    ch = {};
    try {
      const TaskDef& task = find_task(suites_, r.suite(), r.task());
      // What the scene names: an object cell's draws (size, shade, instance) are not known to perception.
      ch.objects = perception::free_objects(sim::load_nominal_scene(task));
      ch.looked_for = perception::appearances(ch.objects);
      ch.episode_id = r.episode_id();
      ctx.log.info("channel={} episode={} looking for {} free objects", r.channel(), r.episode_id(), ch.looked_for.size());
    } catch (const std::exception& e) {
      ctx.log.error("channel={} episode={}: no scene to look for: {}", r.channel(), r.episode_id(), e.what());
      return;
    }
    // The simulator's first observation can come before the request does.
    const auto last = last_seen_.find(r.channel());
    if (last != last_seen_.end() && last->second.first == r.episode_id()) ask(ctx, r.channel(), ch, last->second.second);
  }
  void handle(const msg::RgbdFrame& m, Context& ctx) {
    auto it = channels_.find(m.channel());
    if (it == channels_.end() || m.request_id() != it->second.pending) return;
    auto& ch = it->second;
    if (!m.error().empty() || (!m.episode_id().empty() && m.episode_id() != ch.episode_id)) {
      // Asked before the simulator started the episode, or it could not render: ask again after a while.
      ctx.log.warn("channel={} frame {}: {}", m.channel(), m.request_id(),
                 m.error().empty() ? "shows episode '" + m.episode_id() + "', not this one" : m.error());
      return;
    }
    ch.pending.clear();
    const auto t0 = Clock::now();
    msg::SceneEstimate out;
    out.channel(m.channel());
    out.episode_id(ch.episode_id);
    out.step(m.step());
    out.stamp_s(m.stamp_s());
    out.camera(m.camera());
    try {
      const perception::RgbdFrame frame = to_frame(m);
      const auto candidates = segmenter_->segment(frame.rgb, ch.looked_for);
      const auto estimates = perception::estimate_objects(frame, candidates, ch.objects, cloud_);
      for (std::size_t k = 0; k < estimates.size(); ++k) {
        const perception::EntityEstimate& e = estimates[k];
        if (e.confidence <= 0) continue;
        // Identical objects keep their identities as they move (estimates come in the objects' order).
        if (e.entity == ch.objects[k].appearance.entity) ch.objects[k].prior_xy = e.centroid.head<2>();
        msg::PerceivedEntity p;
        p.entity(e.entity);
        p.centroid({e.centroid.x(), e.centroid.y(), e.centroid.z()});
        p.size({e.size.x(), e.size.y(), e.size.z()});
        p.yaw(std::atan2(e.axes(1, 0), e.axes(0, 0)));
        p.confidence(e.confidence);
        p.points(static_cast<std::uint32_t>(e.points));
        out.seen().push_back(p);
      }
    } catch (const std::exception& e) {
      ctx.log.error("channel={} frame {} not processed: {}", m.channel(), m.request_id(), e.what());
    }
    for (const auto& a : ch.looked_for) out.looked_for().push_back(a.entity);
    out.latency_ms(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    ctx.write<port::SceneEstimate>(out);
    ctx.log.debug("channel={} step={} seen {}/{} in {:.1f} ms", m.channel(), m.step(), out.seen().size(),
                out.looked_for().size(), out.latency_ms());
  }

  void ask(Context& ctx, std::uint32_t channel, ChannelState& ch, std::uint32_t step) {
    msg::RgbdRequest r;
    r.channel(channel);
    r.camera(camera_);
    r.request_id("perception-" + std::to_string(++requests_));
    ctx.write<port::RgbdRequest>(r);
    ch.pending = r.request_id();
    ch.asked_at = Clock::now();
    ch.last_step = step;
  }

  std::string camera_ = "workcell", backend_ = "colour", url_;
  unsigned every_ = 10, frame_timeout_ms_ = 2000;
  double segment_timeout_s_ = 5;
  std::optional<double> table_z_ = 0.0;
  bool search_plane_ = false;
  std::unique_ptr<perception::Segmenter> segmenter_;
  perception::CloudParams cloud_;
  std::map<std::string, SuiteDef> suites_;
  std::map<std::uint32_t, ChannelState> channels_;
  std::map<std::uint32_t, std::pair<std::string, std::uint32_t>> last_seen_;  ///< episode and step per channel
  std::uint64_t requests_ = 0;
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::PerceptionBinding{}); }
