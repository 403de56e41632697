// RGB-D frames over real DDS (loopback), from real processes:
//  - sim_worker answers a request on rt/dh/camera/rgbd/request with one 640x480 frame of the channel's
//    current step: the published intrinsics and pose put each entity's top face at a pixel whose depth is
//    that point's distance along the optical axis and whose colour is the entity's; a request before any
//    episode gets an error frame saying why;
//  - without requests sim_worker renders nothing (no frame, no OpenGL context), and the step rate with and
//    without requests is printed; --rgbd-every N publishes frames at episode start and every N steps;
//  - frames_player plays a recorded folder (written here with OpenCV) frame by frame on request, exactly,
//    and refuses a broken folder naming the file.
#include <algorithm>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "../integration/episode_request.hpp"
#include "../integration/harness.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/cameraPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/scene.hpp"
#include "frame_requests.hpp"
#include "rgbd_pixels.hpp"

namespace dh {
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))];
}

/// A consumer of RGB-D frames, and a governor stand-in driving channel 0 of a sim_worker in lock-step.
class Client {
 public:
  Client()
      : status_(p_, topics::kChannelStatus, dds::Qos::ChannelStatus,
                {[this](const msg::ChannelStatus& s, const auto&) {
                   std::lock_guard l(m_);
                   idle_ = s.state() == msg::CHANNEL_IDLE;
                   cv_.notify_all();
                 },
                 {},
                 {}}),
        obs_(p_, topics::kObservation, dds::Qos::Observation,
             {[this](const msg::Observation& o, const auto&) {
                std::lock_guard l(m_);
                if (o.channel() != 0 || o.episode_id() != kEpisode) return;
                obs_msg_ = o;
                step_ = o.step();
                cv_.notify_all();
              },
              {},
              {}}),
        ep_(p_, topics::kEpisodeRequest, dds::Qos::Episode),
        lease_(p_, topics::kLease, dds::Qos::Lease),
        act_(p_, topics::kAction, dds::Qos::Action),
        rgbd_(p_) {}

  static constexpr const char* kEpisode = "rgbd-e2e";

  // Matching notifies nobody: poll.
  template <class Pred>
  bool poll(std::chrono::milliseconds timeout, Pred pred) {
    const auto end = Clock::now() + timeout;
    std::unique_lock l(m_);
    while (!pred() && Clock::now() < end) cv_.wait_for(l, 20ms);
    return pred();
  }
  bool wait_sim_ready() {
    return poll(30s, [&] {
      return idle_.has_value() && ep_.matched() >= 1 && act_.matched() >= 1 && lease_.matched() >= 1 &&
             rgbd_.matched();
    });
  }
  bool wait_player_ready() {
    return poll(30s, [&] { return rgbd_.matched(); });
  }

  /// "put the bowl on the plate" (goal task 8), seed 4, on channel 0; waits for the step-0 observation.
  bool start(std::uint32_t budget) {
    ep_.write(itest::bowl_on_plate(0, kEpisode, budget));
    renew(0, budget);
    return itest::wait_until(m_, cv_, 20s, [&] { return step_.has_value(); });
  }

  /// One lock-step action (the hand drifts across the table); with `ask`, an RGB-D request right after
  /// the observation, waited for before the next action.
  bool step(std::uint32_t budget, bool ask = false) {
    std::uint32_t t;
    {
      std::lock_guard l(m_);
      t = *step_;
    }
    if (t % 10 == 0) renew(t, budget);
    msg::Action a;
    a.channel(0);
    a.episode_id(kEpisode);
    a.command_id("c0");
    a.step(t);
    a.a({0.1, t < 20 ? 0.2 : -0.2, 0, 0, 0, 0, -1});
    act_.write(a);
    if (!itest::wait_until(m_, cv_, 10s, [&] { return step_ == t + 1; })) return false;
    if (ask) return rgbd_.request(0, "workcell", "s" + std::to_string(t + 1)).has_value();
    return true;
  }

  /// Writes the lease again at the current step, as a live governor does every 250 ms: the lease topic's
  /// 1 s deadline tells the seam whether anyone still leases the channel.
  void keep_lease(std::uint32_t budget) {
    std::uint32_t t;
    {
      std::lock_guard l(m_);
      t = *step_;
    }
    renew(t, budget);
  }

  camtest::FrameRequests& rgbd() { return rgbd_; }
  msg::Observation observation() {
    std::lock_guard l(m_);
    return obs_msg_;
  }

 private:
  void renew(std::uint32_t t, std::uint32_t budget) {
    msg::Lease l;
    l.channel(0);
    l.episode_id(kEpisode);
    l.command_id("c0");
    l.valid_until_step(t + 20);
    l.budget_until_step(budget);
    lease_.write(l);
  }

  dds::Participant p_{"itest_rgbd"};
  std::mutex m_;
  std::condition_variable cv_;
  std::optional<bool> idle_;
  std::optional<std::uint32_t> step_;
  msg::Observation obs_msg_;
  dds::Reader<msg::ChannelStatusPubSubType> status_;
  dds::Reader<msg::ObservationPubSubType> obs_;
  dds::Writer<msg::EpisodeRequestPubSubType> ep_;
  dds::Writer<msg::LeasePubSubType> lease_;
  dds::Writer<msg::ActionPubSubType> act_;
  camtest::FrameRequests rgbd_;
};

using camtest::depth_mm;

/// Which palette colour (linear 0..1) a pixel is, allowing for shading (a factor 0.55 .. 1.5).
std::size_t nearest_colour(const std::uint8_t* c, const std::vector<std::array<double, 4>>& palette) {
  std::size_t best = 0;
  double best_r = 1e9;
  for (std::size_t i = 0; i < palette.size(); ++i) {
    const auto& p = palette[i];
    const double k = std::clamp(
        (c[0] * p[0] + c[1] * p[1] + c[2] * p[2]) / 255.0 / (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), 0.55,
        1.5);
    double r = 0;
    for (int j = 0; j < 3; ++j) r += std::pow(c[j] / 255.0 - k * p[j], 2);
    if (r < best_r) best_r = r, best = i;
  }
  return best;
}

}  // namespace

TEST(RgbdE2E, SimWorkerAnswersARequestWithAMetricFrameOfTheChannelsCurrentStep) {
  itest::IsolatedEnv env;
  cli::Deployment sim({itest::service("sim_worker")}, paths::bin_dir(), env.runs / "logs");
  Client c;
  ASSERT_TRUE(c.wait_sim_ready()) << itest::read_text(env.runs / "logs/sim_worker.log");

  // Before any episode there is no state to show: an error frame, at once.
  const auto early = c.rgbd().request(0, "workcell", "early");
  ASSERT_TRUE(early.has_value()) << "no answer to a request before any episode";
  EXPECT_EQ(early->width(), 0u);
  EXPECT_TRUE(early->rgb().empty());
  EXPECT_NE(early->error().find("has run no episode yet"), std::string::npos) << early->error();

  constexpr std::uint32_t kBudget = 100;
  ASSERT_TRUE(c.start(kBudget));
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(c.step(kBudget));
  const auto f = c.rgbd().request(0, "workcell", "r1");
  ASSERT_TRUE(f.has_value()) << itest::read_text(env.runs / "logs/sim_worker.log");
  EXPECT_EQ(f->error(), "");
  EXPECT_EQ(f->request_id(), "r1");
  EXPECT_EQ(f->camera(), "workcell");
  EXPECT_EQ(f->episode_id(), Client::kEpisode);
  EXPECT_EQ(f->step(), 5u);
  EXPECT_GE(f->stamp_s(), 5 * 0.05 - 1e-9) << "simulated time of step 5 (after the reset's settling)";
  ASSERT_EQ(f->width(), 640u);
  ASSERT_EQ(f->height(), 480u);
  ASSERT_EQ(f->rgb().size(), 640u * 480u * 3u);
  ASSERT_EQ(f->depth().size(), 640u * 480u * 2u);
  // Intrinsics and pose: those configs/cameras.yaml gives.
  const auto config =
      sim::load_cameras_config(paths::config_dir() / "cameras.yaml").for_scene("kitchen_goal").at(0);
  const auto K = sim::pinhole_from_fovy(config.fovy, 640, 480);
  EXPECT_NEAR(f->fx(), K.fx, 1e-9);
  EXPECT_NEAR(f->fy(), K.fy, 1e-9);
  EXPECT_NEAR(f->cx(), 319.5, 1e-12);
  EXPECT_NEAR(f->cy(), 239.5, 1e-12);
  ASSERT_TRUE(f->has_pose());
  sim::CameraPose pose;
  for (int i = 0; i < 3; ++i) {
    pose.position[i] = f->position()[i];
    EXPECT_NEAR(pose.position[i], config.pos[i], 1e-9);
  }
  for (int i = 0; i < 4; ++i) pose.wxyz[i] = f->orientation()[i];
  const auto centre = sim::project(K, pose, config.look_at);
  EXPECT_NEAR(centre.u, K.cx, 1e-6);
  EXPECT_NEAR(centre.v, K.cy, 1e-6);

  // Entities of step 5's observation, projected with what the frame says: depth and colour agree.
  const auto spec = sim::load_task_scene(find_task(load_suites(paths::config_dir()), "goal", 8), 1);
  std::vector<std::array<double, 4>> palette{spec.table_rgba};
  std::vector<std::string> names{"table"};
  for (const auto& e : spec.entities) palette.push_back(e.rgba), names.push_back(e.name);
  const auto obs = c.observation();
  ASSERT_EQ(obs.step(), 5u);
  int checked = 0;
  for (const auto& e : obs.entities()) {
    if (e.name() != "plate" && e.name() != "cream_cheese" && e.name() != "cabinet" &&
        e.name() != "wine_bottle")
      continue;
    // Top face centre; the plate's centre is its disc's top, 1 cm up (configs/assets/plate.yaml).
    const double height = e.name() == "plate" ? 0.010 : 2 * e.half_extents()[2];
    const auto& ep = e.pose().p();
    const std::array<double, 3> top{ep[0], ep[1], ep[2] + height};
    const auto p = sim::project(K, pose, top);
    ASSERT_TRUE(p.u >= 0 && p.u <= 639 && p.v >= 0 && p.v <= 479) << e.name();
    const auto row = static_cast<std::size_t>(std::lround(p.v)),
               col = static_cast<std::size_t>(std::lround(p.u));
    const double got = depth_mm(*f, row, col) / 1000.0;
    const std::uint8_t* px = f->rgb().data() + 3 * (row * 640 + col);
    const auto is = names[nearest_colour(px, palette)];
    std::printf("%-13s at pixel (%.1f, %.1f): depth %.3f m, expected %.4f m; colour %d,%d,%d looks like %s\n",
                e.name().c_str(), p.u, p.v, got, p.z, px[0], px[1], px[2], is.c_str());
    EXPECT_NEAR(got, p.z, 0.004) << e.name();
    EXPECT_EQ(is, e.name());
    ++checked;
  }
  EXPECT_EQ(checked, 4);

  // Request -> frame latency over the deployment's transport (render + read + publish + delivery).
  std::vector<double> ms;
  for (int i = 0; i < 20; ++i) {
    c.keep_lease(kBudget);  // twenty frames can take longer than the lease's deadline under load
    double l = 0;
    ASSERT_TRUE(c.rgbd().request(0, "workcell", "lat" + std::to_string(i), 10s, &l).has_value())
        << "request " << i << " lost";
    ms.push_back(l);
  }
  std::printf("request -> frame (640x480 RGB-D, 20 requests): p50 %.1f ms, p90 %.1f ms, max %.1f ms\n",
              percentile(ms, 0.5), percentile(ms, 0.9), percentile(ms, 1.0));
  // One step later: the next step's state, 50 ms of simulated time later.
  ASSERT_TRUE(c.step(kBudget));
  const auto g = c.rgbd().request(0, "workcell", "r2");
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->step(), 6u);
  EXPECT_NEAR(g->stamp_s() - f->stamp_s(), 0.05, 1e-9);
  EXPECT_NE(g->rgb(), f->rgb()) << "the hand moved; the image did not";
  // A camera the worker does not have is not its to answer (a frames_player might serve it).
  EXPECT_FALSE(c.rgbd().request(0, "no_such_camera", "nobody", 1s).has_value());
  EXPECT_TRUE(sim.exited().empty()) << "sim_worker crashed";
}

TEST(RgbdE2E, WithoutRequestsSimWorkerRendersNothing) {
  itest::IsolatedEnv env;
  auto sim = std::make_unique<cli::Deployment>(std::vector<cli::ServiceSpec>{itest::service("sim_worker")},
                                               paths::bin_dir(), env.runs / "logs");
  Client c;
  ASSERT_TRUE(c.wait_sim_ready()) << itest::read_text(env.runs / "logs/sim_worker.log");
  constexpr std::uint32_t kBudget = 200, kSteps = 60;
  ASSERT_TRUE(c.start(kBudget));
  auto t0 = Clock::now();
  for (std::uint32_t i = 0; i < kSteps; ++i) ASSERT_TRUE(c.step(kBudget));
  const double plain = kSteps / std::chrono::duration<double>(Clock::now() - t0).count();
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(c.rgbd().received(), 0u) << "frames without a request";
  const std::string log = itest::read_text(env.runs / "logs/sim_worker.log");
  EXPECT_EQ(log.find("OpenGL context for RGB-D"), std::string::npos)
      << "an OpenGL context without a request: " << log;
  EXPECT_NE(log.find("RGB-D cameras on request: workcell"), std::string::npos) << log;
  // The same channel, a frame requested (and received) after every step.
  t0 = Clock::now();
  for (std::uint32_t i = 0; i < kSteps; ++i) ASSERT_TRUE(c.step(kBudget, true)) << "step " << i;
  const double asked = kSteps / std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_EQ(c.rgbd().received(), kSteps);
  std::printf(
      "lock-step rate: %.1f steps/s without requests, %.1f steps/s with a 640x480 RGB-D frame per step\n",
      plain, asked);
  sim.reset();  // the worker reports its render and publish times as it ends
  const std::string end_log = itest::read_text(env.runs / "logs/sim_worker.log");
  const auto at = end_log.find("RGB-D frames,");
  ASSERT_NE(at, std::string::npos) << end_log;
  const auto line_start = end_log.rfind("channel=", at);
  std::printf("sim_worker: %s\n", end_log.substr(line_start, end_log.find('\n', at) - line_start).c_str());
}

TEST(RgbdE2E, RgbdEveryPublishesFramesAtEpisodeStartAndEveryNSteps) {
  itest::IsolatedEnv env;
  auto sim = std::make_unique<cli::Deployment>(
      // with --cameras too: both rigs share the channel's one OpenGL context
      std::vector<cli::ServiceSpec>{
          itest::service("sim_worker", {"--rgbd-every", "5", "--cameras", "agentview"})},
      paths::bin_dir(), env.runs / "logs");
  Client c;
  ASSERT_TRUE(c.wait_sim_ready()) << itest::read_text(env.runs / "logs/sim_worker.log");
  // Our reader has matched the worker's writer; give the writer the moment it takes to match our reader
  // (frames are volatile: one written before that is not for us).
  std::this_thread::sleep_for(500ms);
  constexpr std::uint32_t kBudget = 100;
  ASSERT_TRUE(c.start(kBudget));
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(c.step(kBudget));
  std::set<std::uint32_t> steps;
  ASSERT_TRUE(c.rgbd().wait(10s, [&](const std::vector<msg::RgbdFrame>& frames) {
    steps.clear();
    for (const auto& f : frames) {
      EXPECT_EQ(f.request_id(), "");
      EXPECT_EQ(f.error(), "");
      EXPECT_EQ(f.width(), 640u);
      steps.insert(f.step());
    }
    return steps.count(10) > 0;
  }));
  // Keep-last 1: a frame whose lost fragments are still being repaired when the next one is written is
  // superseded (the newest wins), so only the last is sure to arrive; the worker must have made all three.
  for (const auto s : steps) EXPECT_TRUE(s == 0 || s == 5 || s == 10) << s;
  std::printf("%zu of the 3 periodic frames arrived:", steps.size());
  for (const auto s : steps) std::printf(" %u", s);
  std::printf("\n");
  sim.reset();
  const std::string log = itest::read_text(env.runs / "logs/sim_worker.log");
  // Every RGB-D camera of configs/cameras.yaml at steps 0, 5 and 10.
  const auto cameras = sim::load_cameras_config(paths::config_dir() / "cameras.yaml").cameras.size();
  EXPECT_NE(log.find("channel=0 " + std::to_string(3 * cameras) + " RGB-D frames"), std::string::npos) << log;
}

/// A recorded folder of `n` frames, 64 x 48: colour (r, c) = (4 c, 5 r, 50 k), depth 500 + 10 k + r mm.
void write_recording(const fs::path& dir, int n, bool with_pose = true) {
  fs::create_directories(dir / "color");
  fs::create_directories(dir / "depth");
  std::ofstream(dir / "intrinsics.yaml")
      << "width: 64\nheight: 48\nfx: 60.5\nfy: 61.5\nppx: 31.25\nppy: 23.75\n"
         "depth_scale: 0.001\n"
      << (with_pose ? "pose:\n  position: [0.5, 0.1, 1.2]\n  orientation: [0, 1, 0, 0]\n" : "");
  for (int k = 0; k < n; ++k) {
    cv::Mat bgr(48, 64, CV_8UC3), depth(48, 64, CV_16UC1);
    for (int r = 0; r < 48; ++r)
      for (int col = 0; col < 64; ++col) {
        bgr.at<cv::Vec3b>(r, col) =
            cv::Vec3b(static_cast<uchar>(50 * k), static_cast<uchar>(5 * r), static_cast<uchar>(4 * col));
        depth.at<std::uint16_t>(r, col) = static_cast<std::uint16_t>(500 + 10 * k + r);
      }
    char stem[16];
    std::snprintf(stem, sizeof stem, "%06d", k);
    cv::imwrite((dir / "color" / (std::string(stem) + ".png")).string(), bgr);
    cv::imwrite((dir / "depth" / (std::string(stem) + ".png")).string(), depth);
  }
}

TEST(RgbdE2E, FramesPlayerPlaysARecordedFolderFrameByFrameOnRequest) {
  itest::IsolatedEnv env;
  const fs::path rec = env.runs / "my_cell";
  write_recording(rec, 3);
  cli::Deployment player({itest::service("frames_player", {"--folder", rec.string(), "--channel", "3"})},
                         paths::bin_dir(), env.runs / "logs");
  Client c;
  ASSERT_TRUE(c.wait_player_ready()) << itest::read_text(env.runs / "logs/frames_player.log");
  EXPECT_FALSE(c.rgbd().request(0, "workcell", "other-channel", 1s).has_value())
      << "answered another channel's request";
  for (int i = 0; i < 4; ++i) {
    const auto f = c.rgbd().request(3, "workcell", "p" + std::to_string(i));
    ASSERT_TRUE(f.has_value()) << "request " << i << ": "
                               << itest::read_text(env.runs / "logs/frames_player.log");
    const int k = i % 3;  // in order, then again from the first
    EXPECT_EQ(f->error(), "");
    EXPECT_EQ(f->channel(), 3u);
    EXPECT_EQ(f->step(), static_cast<std::uint32_t>(k));
    EXPECT_NE(f->source().find("my_cell"), std::string::npos) << f->source();
    ASSERT_EQ(f->width(), 64u);
    ASSERT_EQ(f->height(), 48u);
    EXPECT_EQ(f->fx(), 60.5);
    EXPECT_EQ(f->fy(), 61.5);
    EXPECT_EQ(f->cx(), 31.25);
    EXPECT_EQ(f->cy(), 23.75);
    EXPECT_TRUE(f->has_pose());
    EXPECT_EQ(f->position()[2], 1.2);
    EXPECT_EQ(f->orientation()[1], 1.0);
    ASSERT_EQ(f->rgb().size(), 64u * 48u * 3u);
    ASSERT_EQ(f->depth().size(), 64u * 48u * 2u);
    for (const auto& [r, col] : {std::pair<std::size_t, std::size_t>{0, 0}, {47, 63}, {10, 20}}) {
      const std::uint8_t* px = f->rgb().data() + 3 * (r * 64 + col);
      EXPECT_EQ(px[0], 4 * col);
      EXPECT_EQ(px[1], 5 * r);
      EXPECT_EQ(px[2], 50 * k);
      EXPECT_EQ(depth_mm(*f, r, col), 500 + 10 * k + r);
    }
  }
  EXPECT_TRUE(player.exited().empty()) << "frames_player ended";
}

TEST(RgbdE2E, FramesPlayerAtARateAndAnUndecodableFrameAnsweredWithItsName) {
  itest::IsolatedEnv env;
  const fs::path rec = env.runs / "rated";
  write_recording(rec, 3, false);
  std::ofstream(rec / "color/000001.png") << "not a PNG";  // found only when frame 1 is played
  cli::Deployment player({itest::service("frames_player", {"--folder", rec.string(), "--rate-hz", "20"})},
                         paths::bin_dir(), env.runs / "logs");
  Client c;
  ASSERT_TRUE(c.wait_player_ready()) << itest::read_text(env.runs / "logs/frames_player.log");
  std::vector<msg::RgbdFrame> got;
  ASSERT_TRUE(c.rgbd().wait(10s,
                            [&](const std::vector<msg::RgbdFrame>& frames) {
                              got = frames;
                              return got.size() >= 6;
                            }))
      << got.size() << " frames";
  // In order, round and round (the first few may have gone before the reader matched).
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_EQ(got[i].step(), (got[i - 1].step() + 1) % 3);
  for (const auto& f : got) {
    EXPECT_EQ(f.request_id(), "");
    EXPECT_FALSE(f.has_pose());
    if (f.step() == 1) {
      EXPECT_NE(f.error().find((rec / "color/000001.png").string()), std::string::npos) << f.error();
      EXPECT_EQ(f.width(), 0u);
    } else {
      EXPECT_EQ(f.error(), "");
      EXPECT_EQ(f.width(), 64u);
    }
  }
  // A request now gets the frame published last, with the request's id.
  const auto r = c.rgbd().request(0, "workcell", "while-playing");
  ASSERT_TRUE(r.has_value());
  EXPECT_LT(r->step(), 3u);
  EXPECT_TRUE(player.exited().empty());
}

TEST(RgbdE2E, FramesPlayerRefusesABrokenFolderNamingTheFile) {
  itest::IsolatedEnv env;
  const fs::path rec = env.runs / "broken";
  write_recording(rec, 2);
  fs::remove(rec / "depth/000001.png");
  cli::Deployment player({itest::service("frames_player", {"--folder", rec.string()})}, paths::bin_dir(),
                         env.runs / "logs");
  const auto t0 = Clock::now();
  std::vector<std::string> exited;
  while ((exited = player.exited()).empty() && Clock::now() - t0 < 15s) std::this_thread::sleep_for(50ms);
  ASSERT_EQ(exited, std::vector<std::string>{"frames_player"}) << "frames_player kept running";
  const std::string log = itest::read_text(env.runs / "logs/frames_player.log");
  EXPECT_NE(log.find((rec / "color/000001.png").string()), std::string::npos) << log;
  EXPECT_NE(log.find("no depth image"), std::string::npos) << log;
}

}  // namespace dh
