// rgbd_camera: a live RGB-D camera (OpenNI2: openni_source.hpp) on rt/dh/camera/rgbd, answering requests
// as sim_worker's workcell camera and frames_player do, so perception runs on the cell as it is now.
//
// Reads   rt/dh/camera/rgbd/request (RgbdRequest) for --channel and the camera's name
// Writes  rt/dh/camera/rgbd         (RgbdFrame)   one frame per request, with the request's id, taken
//                                                 after the request came; with --rate-hz R also R frames
//                                                 per second, request id ""
// A frame the device does not give within the timeout is answered with an error frame and logged; three
// in a row end the process with the reason (its unit restarts it, opening the camera anew).
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <optional>

#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/frames/rate_schedule.hpp"
#include "dh/frames/recording.hpp"
#include "dh/msg/cameraPubSubTypes.h"
#include "dh/rgbd_camera/frame_convert.hpp"
#include "dh/rgbd_camera/openni_source.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

int run(int argc, char** argv) {
  CLI::App app{"rgbd_camera: a live RGB-D camera through OpenNI2 on " + std::string(topics::kRgbd)};
  camera::SourceOptions opt;
  std::string camera_file, camera_name, registration = "device";
  unsigned channel = 0, timeout_ms = 2000;
  double rate_hz = 0;
  app.add_option("--device", opt.device, "OpenNI2 URI of the device; default: the first device found");
  app.add_option(
         "--camera-file", camera_file,
         "the camera's file (frames_player's intrinsics.yaml keys): camera name, pose, and intrinsics "
         "from a calibration (without them, from the device's fields of view)")
      ->check(CLI::ExistingFile);
  app.add_option("--camera", camera_name,
                 "camera name to publish as (default: the file's `camera`, else workcell)");
  app.add_option("--channel", channel,
                 "the channel the frames are published for (requests for it are answered)");
  app.add_option("--width", opt.width,
                 "image width both streams run at (with --height; default the device's)");
  app.add_option("--height", opt.height, "image height");
  app.add_option("--fps", opt.fps, "frame rate of the mode (default: any the size comes at)");
  app.add_option(
         "--registration", registration,
         "device: the device maps depth onto the colour camera's pixels (refused at start if it cannot); "
         "none: depth as the device gives it")
      ->check(CLI::IsMember({"device", "none"}));
  app.add_option("--timeout-ms", timeout_ms, "a frame must come within this")->check(CLI::Range(1u, 60000u));
  app.add_option("--rate-hz", rate_hz, "also publish frames at this rate (0: only on request)")
      ->check(CLI::Range(0.0, 60.0));
  bool list = false;
  app.add_flag("--list-devices", list, "print the URIs of the devices OpenNI2 sees, and exit");
  CLI11_PARSE(app, argc, argv);
  if (list) {
    try {
      const auto devices = camera::list_devices();
      for (const auto& d : devices) std::printf("%s\n", d.c_str());
      if (devices.empty())
        std::printf(
            "no device (plugged in? its OpenNI2 driver in OpenNI2's drivers folder? "
            "services/rgbd_camera/README.md)\n");
      return 0;
    } catch (const camera::SourceError& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  }
  opt.registration = registration == "device";
  opt.timeout = std::chrono::milliseconds(timeout_ms);
  auto log = make_logger("rgbd_camera");

  frames::CameraFile cam;
  std::optional<camera::OpenNiSource> source;
  std::optional<dds::Participant> participant;
  std::optional<dds::Writer<msg::RgbdFramePubSubType>> out;
  std::optional<dds::Reader<msg::RgbdRequestPubSubType>> in;
  EventQueue<msg::RgbdRequest> requests;
  std::uint64_t sent = 0, failed = 0;
  // A device that stops sending is not found again by this process: after this many failed frames in a
  // row it ends with the reason, and whoever runs it (systemd's Restart=on-failure) opens the camera anew.
  constexpr int kFailuresToEnd = 3;
  int failing = 0;

  const auto publish = [&](const std::string& request_id) {
    msg::RgbdFrame m;
    m.channel(channel);
    m.camera(cam.camera);
    m.source("rgbd_camera " + source->uri());
    m.request_id(request_id);
    m.has_pose(cam.has_pose);
    m.position(cam.position);
    m.orientation(cam.orientation);
    try {
      const camera::LiveFrame f = source->grab();
      m.step(static_cast<std::uint32_t>(f.index));
      m.width(static_cast<std::uint32_t>(f.width));
      m.height(static_cast<std::uint32_t>(f.height));
      m.fx(cam.K.fx);
      m.fy(cam.K.fy);
      m.cx(cam.K.cx);
      m.cy(cam.K.cy);
      m.rgb(f.rgb);
      m.depth(frames::depth_le_bytes(f.depth_mm));
      failing = 0;
    } catch (const camera::SourceError& e) {
      m.error(e.what());
      ++failed;
      ++failing;
      log->error("request '{}': {}", request_id, e.what());
    }
    m.stamp_s(std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
    out->write(m);
    ++sent;
  };

  frames::RateSchedule schedule(rate_hz);
  ManagedService service;
  service.transitions.configure = [&] {
    if (!camera_file.empty()) cam = frames::read_camera_file(camera_file, false);
    if (!camera_name.empty()) cam.camera = camera_name;
    source.emplace(opt);
    if (cam.has_intrinsics) {
      if (cam.K.width != source->width() || cam.K.height != source->height())
        throw std::runtime_error(camera_file + ": its intrinsics are for " + std::to_string(cam.K.width) +
                                 "x" + std::to_string(cam.K.height) + " but the camera runs at " +
                                 std::to_string(source->width()) + "x" + std::to_string(source->height()) +
                                 " (calibrate at this size, or ask for that size with --width and --height)");
    } else {
      try {
        cam.K =
            camera::intrinsics_from_fov(source->width(), source->height(), source->hfov(), source->vfov());
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error("camera " + source->uri() + ": " + e.what());
      }
    }
    // One frame before anything is announced, so a camera that sends nothing fails here.
    source->grab();
    log->info("{}; fx={:.2f} fy={:.2f} cx={:.2f} cy={:.2f} ({}), pose {}", source->describe(), cam.K.fx,
              cam.K.fy, cam.K.cx, cam.K.cy,
              cam.has_intrinsics ? "from " + camera_file : std::string("from the fields of view"),
              cam.has_pose ? "given" : "unknown");
    participant.emplace("dh_rgbd_camera");
    out.emplace(*participant, topics::kRgbd, dds::Qos::Rgbd);
  };
  service.transitions.activate = [&] {
    in.emplace(*participant, topics::kRgbdRequest, dds::Qos::RgbdRequest,
               dds::Reader<msg::RgbdRequestPubSubType>::Callbacks{
                   [&](const msg::RgbdRequest& r, const auto&) {
                     if (r.channel() == channel && r.camera() == cam.camera) requests.push(r);
                   },
                   {},
                   {}});
    log->info("serving channel={} camera={} on {} domain={}{}", channel, cam.camera, topics::kRgbd,
              dds::domain_id(),
              rate_hz > 0 ? " at " + std::to_string(rate_hz) + " Hz" : std::string(", on request"));
    schedule.start(Clock::now());
  };
  service.transitions.deactivate = [&] {
    in.reset();
    log->info("{} frames sent, {} of them errors", sent, failed);
  };
  service.transitions.shutdown = [&] {
    in.reset();
    out.reset();
    participant.reset();
    source.reset();
  };
  service.step = [&] {
    if (failing >= kFailuresToEnd)
      throw std::runtime_error("camera " + source->uri() + ": " + std::to_string(failing) +
                               " frames in a row did not come; ending, to be started again");
    if (auto r = requests.pop(schedule.wait(Clock::now(), std::chrono::milliseconds(100))))
      publish(r->request_id());
    if (schedule.due(Clock::now())) publish("");
  };
  return run_managed(*log, std::move(service));
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
