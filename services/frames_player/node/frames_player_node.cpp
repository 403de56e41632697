// frames_player: plays a folder of recorded RGB-D frames (README.md: colour PNG + 16-bit depth PNG +
// intrinsics.yaml) on rt/dh/camera/rgbd, as sim_worker's workcell camera does, so perception can run on
// frames from a real cell.
//
// Reads   rt/dh/camera/rgbd/request (RgbdRequest) for --channel and the recording's camera
// Writes  rt/dh/camera/rgbd         (RgbdFrame)   one frame per request, with the request's id; with
//                                                 --rate-hz R also R frames per second, request id ""
// Which frame: on request, the next frame of the recording (the first request gets the first frame;
// after the last it starts again, or stays on the last with --no-loop); --hold answers every request
// with frame --start. With --rate-hz the timer advances the recording and requests get the frame
// published last. A frame that cannot be decoded is answered with an error frame naming the file.
#include <CLI/CLI.hpp>
#include <chrono>
#include <optional>

#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/frames/rate_schedule.hpp"
#include "dh/frames/recording.hpp"
#include "dh/msg/cameraPubSubTypes.h"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

class Player {
 public:
  Player(frames::Recording rec, std::uint32_t channel, bool loop, bool hold, std::size_t start,
         dds::Writer<msg::RgbdFramePubSubType>& out, spdlog::logger& log)
      : rec_(std::move(rec)),
        channel_(channel),
        loop_(loop),
        hold_(hold),
        next_(start),
        out_(out),
        log_(log) {}

  /// Answers a request (`advance`: with the next frame; otherwise with the frame published last).
  void publish(const std::string& request_id, bool advance) {
    std::size_t index = current_.value_or(next_);
    if (advance || !current_) {
      index = next_;
      if (!hold_) next_ = next_ + 1 < rec_.frames.size() ? next_ + 1 : (loop_ ? 0 : next_);
    }
    current_ = index;
    const auto t0 = Clock::now();
    msg::RgbdFrame m;
    m.channel(channel_);
    m.camera(rec_.camera);
    m.source("frames_player " + rec_.folder.string());
    m.step(static_cast<std::uint32_t>(index));
    m.request_id(request_id);
    m.stamp_s(std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
    m.has_pose(rec_.has_pose);
    m.position(rec_.position);
    m.orientation(rec_.orientation);
    try {
      if (!decoded_ || decoded_->index != index) decoded_ = frames::read_frame(rec_, index);
      m.width(static_cast<std::uint32_t>(decoded_->width));
      m.height(static_cast<std::uint32_t>(decoded_->height));
      m.fx(rec_.K.fx);
      m.fy(rec_.K.fy);
      m.cx(rec_.K.cx);
      m.cy(rec_.K.cy);
      m.rgb(decoded_->rgb);
      m.depth(frames::depth_le_bytes(decoded_->depth_mm));
    } catch (const std::exception& e) {
      decoded_.reset();
      m.error(e.what());
      log_.error("frame {} ({}) cannot be played: {}", index, rec_.frames[index].stem, e.what());
    }
    out_.write(m);
    ++sent_;
    log_.debug("frame {} ({}) request '{}' sent in {:.1f} ms", index, rec_.frames[index].stem, request_id,
               std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }

  std::uint64_t sent() const { return sent_; }

 private:
  frames::Recording rec_;
  std::uint32_t channel_;
  bool loop_, hold_;
  std::size_t next_;
  std::optional<std::size_t> current_;
  std::optional<frames::Frame> decoded_;
  dds::Writer<msg::RgbdFramePubSubType>& out_;
  spdlog::logger& log_;
  std::uint64_t sent_ = 0;
};

int run(int argc, char** argv) {
  CLI::App app{
      "frames_player: plays recorded RGB-D frames (colour PNG, 16-bit depth PNG, intrinsics.yaml) on " +
      std::string(topics::kRgbd)};
  std::string folder, camera;
  unsigned channel = 0;
  double rate_hz = 0;
  bool no_loop = false, hold = false;
  std::size_t start = 0;
  app.add_option("--folder", folder, "the recording: intrinsics.yaml, color/<stem>.png, depth/<stem>.png")
      ->required();
  app.add_option("--channel", channel,
                 "the channel the frames are published for (requests for it are answered)");
  app.add_option("--camera", camera,
                 "camera name to publish as (default: intrinsics.yaml's `camera`, else workcell)");
  app.add_option("--rate-hz", rate_hz,
                 "also publish frames at this rate, advancing the recording (0: only on request)")
      ->check(CLI::Range(0.0, 100.0));
  app.add_flag("--no-loop", no_loop, "stay on the last frame instead of starting again");
  app.add_flag("--hold", hold, "answer every request with frame --start");
  app.add_option("--start", start, "index of the first frame played");
  CLI11_PARSE(app, argc, argv);
  auto log = make_logger("frames_player");
  std::string cam;
  std::optional<dds::Participant> participant;
  std::optional<dds::Writer<msg::RgbdFramePubSubType>> out;
  std::optional<Player> player;
  std::optional<dds::Reader<msg::RgbdRequestPubSubType>> in;
  EventQueue<msg::RgbdRequest> requests;
  frames::RateSchedule schedule(rate_hz);
  ManagedService service;
  service.transitions.configure = [&] {
    frames::Recording rec = frames::open_recording(folder);
    if (!camera.empty()) rec.camera = camera;
    if (start >= rec.frames.size())
      throw std::runtime_error("--start " + std::to_string(start) + " but " + folder + " has " +
                               std::to_string(rec.frames.size()) + " frames");
    // The first frame is decoded before anything is announced, so a broken recording fails here.
    frames::read_frame(rec, start);
    log->info("{}: {} frames {}x{} fx={:.2f} fy={:.2f} cx={:.2f} cy={:.2f} depth_scale={} pose={}", folder,
              rec.frames.size(), rec.K.width, rec.K.height, rec.K.fx, rec.K.fy, rec.K.cx, rec.K.cy,
              rec.depth_scale, rec.has_pose ? "given" : "unknown");
    cam = rec.camera;
    participant.emplace("dh_frames_player");
    out.emplace(*participant, topics::kRgbd, dds::Qos::Rgbd);
    player.emplace(std::move(rec), channel, !no_loop, hold, start, *out, *log);
  };
  service.transitions.activate = [&] {
    in.emplace(*participant, topics::kRgbdRequest, dds::Qos::RgbdRequest,
               dds::Reader<msg::RgbdRequestPubSubType>::Callbacks{
                   [&](const msg::RgbdRequest& r, const auto&) {
                     if (r.channel() == channel && r.camera() == cam) requests.push(r);
                   },
                   {},
                   {}});
    log->info("playing as channel={} camera={} on {} domain={}{}", channel, cam, topics::kRgbd, dds::domain_id(),
              rate_hz > 0 ? " at " + std::to_string(rate_hz) + " Hz" : std::string(", on request"));
    schedule.start(Clock::now());
  };
  service.transitions.deactivate = [&] {
    in.reset();
    log->info("{} frames sent", player->sent());
  };
  service.transitions.shutdown = [&] {
    in.reset();
    player.reset();
    out.reset();
    participant.reset();
  };
  service.step = [&] {
    if (auto r = requests.pop(schedule.wait(Clock::now(), std::chrono::milliseconds(100))))
      player->publish(r->request_id(), rate_hz <= 0);
    if (schedule.due(Clock::now())) player->publish("", true);
  };
  return run_managed(*log, std::move(service));
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
