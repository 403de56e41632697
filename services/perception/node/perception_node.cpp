// perception: scene estimates from RGB-D frames, for arms that ground from perception.
// Reads   rt/dh/episode/request (Episode)      which scene a channel runs: the free objects to look for,
//                                              for episodes whose request says grounding "perception"
//         rt/dh/episode/result  (Episode)      the channel's episode is over
//         rt/dh/observation     (Observation)  when to look: step 0, then every --every-steps
//         rt/dh/camera/rgbd     (Rgbd)         the frames it asked for
// Writes  rt/dh/camera/rgbd/request (RgbdRequest)  one frame of the channel's current state
//         rt/dh/perception/scene    (Observation)  one SceneEstimate per frame: looked for, seen, parts, latency
// Parameters: --camera (workcell), --parts-camera (none: the fixtures' parts are not looked at), --every-steps (10), --backend colour|http, --segment-url,
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
#include "dh/perception/core.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/scene.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;
using dds::In;
using dds::Sample;

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

/// perception::PerceptionCore's binding: message conversions, the segmenter and the scene source.
class PerceptionBinding {
 public:
  using Inputs = dds::Inputs<In<port::EpisodeRequest>, In<port::EpisodeResult>,
                             In<port::Observation, dds::kAddressed>, In<port::Rgbd>>;
  using Outputs = dds::Outputs<port::RgbdRequest, port::SceneEstimate>;
  using Context = dds::Context<PerceptionBinding>;

  std::string name() const { return "dh_perception"; }
  std::string description() const { return "scene estimates from RGB-D frames (OpenCV masks, PCL boxes)"; }
  const Ports& ports() const { return perception::PerceptionCore::ports(); }
  void options(CLI::App& app) {
    app.add_option("--camera", settings_.camera,
                   "camera to ask for (configs/cameras.yaml, or what frames_player plays as)");
    app.add_option("--parts-camera", settings_.parts_camera,
                   "camera whose depth the fixtures' articulated parts are fitted to (configs/cameras.yaml: front); "
                   "none: the governor keeps the parts' values its observations carry");
    app.add_option("--every-steps", settings_.every_steps, "ask for a frame every N control steps (and at step 0)")
        ->check(CLI::PositiveNumber);
    app.add_option("--backend", backend_, "colour (from the scene description) | http (a SAM-style server)")
        ->check(CLI::IsMember({"colour", "http"}));
    app.add_option("--segment-url", url_, "http backend: the server's endpoint, e.g. http://127.0.0.1:8765/segment");
    app.add_option("--segment-timeout-s", segment_timeout_s_, "http backend: whole-request timeout");
    app.add_option("--frame-timeout-ms", frame_timeout_ms_, "a frame not answered this long is asked for again");
    app.add_option("--still-every-ms", still_every_ms_,
                   "a robot that has stood still this long is looked at again (another frame of its step)");
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
    perception::CloudParams cloud;
    if (!search_plane_) cloud.support_z = table_z_;
    suites_ = load_suites(paths::config_dir());
    settings_.frame_timeout = std::chrono::milliseconds(frame_timeout_ms_);
    settings_.still_every = std::chrono::milliseconds(still_every_ms_);
    core_ = std::make_unique<perception::PerceptionCore>(
        settings_,
        [this](const std::string& suite, std::uint32_t task) {
          return perception::free_objects(sim::load_nominal_scene(find_task(suites_, suite, task)));
        },
        [this](const std::string& suite, std::uint32_t task) {
          return perception::articulated_parts(sim::load_nominal_scene(find_task(suites_, suite, task)));
        },
        *segmenter_, cloud);
  }
  void activate(Context& ctx) {
    ctx.log.info("backend={} camera={} parts camera={} every {} steps; domain={} up", backend_, settings_.camera,
                 settings_.parts_camera.empty() ? "none" : settings_.parts_camera, settings_.every_steps,
                 dds::domain_id());
  }
  void on(const Sample<port::EpisodeRequest>& s, Context& ctx) {
    const auto& r = s.msg;
    carry(ctx, core_->on_episode(r.channel(), r.episode_id(), r.grounding(), r.suite(), r.task(), Clock::now()));
  }
  void on(const Sample<port::EpisodeResult>& s, Context&) { core_->on_result(s.msg.channel(), s.msg.episode_id()); }
  void on(const Sample<port::Observation>& s, Context& ctx) {
    if (s.msg.again()) return;  // a step said again for a starting command's capability: seen already
    carry(ctx, core_->on_observation(s.msg.channel(), s.msg.episode_id(), s.msg.step(), Clock::now()));
  }
  void on(const Sample<port::Rgbd>& s, Context& ctx) {
    const msg::RgbdFrame& m = s.msg;
    carry(ctx, core_->on_frame({m.channel(), m.request_id(), m.episode_id(), m.camera(), m.error(), m.step(),
                                m.stamp_s()},
                               [&m] { return to_frame(m); }));
  }
  void tick(Context& ctx) { carry(ctx, core_->on_tick(Clock::now())); }

 private:
  void carry(Context& ctx, const perception::PerceptionEffects& fx) {
    for (const auto& n : fx.notes) {
      using L = perception::Note::Level;
      if (n.level == L::Error) ctx.log.error("{}", n.text);
      else if (n.level == L::Warn) ctx.log.warn("{}", n.text);
      else ctx.log.info("{}", n.text);
    }
    for (const auto& a : fx.asks) {
      msg::RgbdRequest r;
      r.channel(a.channel);
      r.camera(a.camera);
      r.request_id(a.request_id);
      ctx.write<port::RgbdRequest>(r);
    }
    if (!fx.estimate) return;
    const perception::SceneOut& e = *fx.estimate;
    msg::SceneEstimate out;
    out.channel(e.channel);
    out.episode_id(e.episode_id);
    out.step(e.step);
    out.stamp_s(e.stamp_s);
    out.camera(e.camera);
    for (const perception::EntityEstimate& x : e.seen) {
      msg::PerceivedEntity p;
      p.entity(x.entity);
      p.centroid({x.centroid.x(), x.centroid.y(), x.centroid.z()});
      p.size({x.size.x(), x.size.y(), x.size.z()});
      p.yaw(x.yaw());
      p.confidence(x.confidence);
      p.points(static_cast<std::uint32_t>(x.points));
      if (const auto id = e.identities.find(x.entity); id != e.identities.end()) {
        p.kind(id->second.kind);
        p.category(id->second.category);
        p.colour(id->second.colour);
      }
      out.seen().push_back(p);
    }
    out.looked_for(e.looked_for);
    for (const perception::PartEstimate& x : e.parts) {
      msg::PerceivedPart p;
      p.entity(x.name);
      p.joint(x.joint);
      p.confidence(x.confidence);
      p.points(static_cast<std::uint32_t>(x.support));
      const Eigen::Quaterniond q(x.world_from_part.rotation());
      for (const auto& [name, at] : x.riders) {
        msg::RiderPose r;
        r.entity(name);
        r.p({at.x(), at.y(), at.z()});
        r.q({q.w(), q.x(), q.y(), q.z()});
        p.riders().push_back(r);
      }
      out.parts().push_back(p);
    }
    out.latency_ms(e.latency_ms);
    ctx.write<port::SceneEstimate>(out);
    ctx.log.debug("channel={} step={} seen {}/{}, {} parts in {:.1f} ms", e.channel, e.step, out.seen().size(),
                  out.looked_for().size(), out.parts().size(), out.latency_ms());
  }

  perception::CoreSettings settings_;
  std::string backend_ = "colour", url_;
  unsigned frame_timeout_ms_ = 2000;
  unsigned still_every_ms_ = 250;
  double segment_timeout_s_ = 5;
  std::optional<double> table_z_ = 0.0;
  bool search_plane_ = false;
  std::unique_ptr<perception::Segmenter> segmenter_;
  std::map<std::string, SuiteDef> suites_;
  std::unique_ptr<perception::PerceptionCore> core_;
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::PerceptionBinding{}); }
