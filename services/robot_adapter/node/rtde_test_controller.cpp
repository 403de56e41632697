// rtde_test_controller: the RTDE test controller as a process, a test double for the metal, not a robot.
// It serves RTDE and a script port on 127.0.0.1, backed by the UR7e in MuJoCo (simulated_ur.hpp), for the
// cell's dry run and for trying the adapter by hand. Every second it logs the arm's peak joint speed, so a
// stop can be seen. Parameters: --port (RTDE), --script-port, --gripper-port (the Robotiq URCap's server,
// robotiq_socket.hpp), --urdf, --ready-q (6 joint values, rad).
//
// With --cell NAME --task N --seed S the arm stands on that benchmark scene's mount instead, among the
// scene's fixtures and objects where the seed places them (--robot: the profile on the mount, default
// ur7e). It then is the cell's cameras' double too, on DDS:
//
// Reads   rt/dh/camera/rgbd/request (RgbdRequest) for --channel and an RGB-D camera of configs/cameras.yaml
// Writes  rt/dh/camera/rgbd         (RgbdFrame)   that camera's frame of the world now, with the request's id
//
// and --entities-out FILE writes the scene's fixtures, their parts and the table's regions in the format
// robot_adapter --entities reads (cell_entities.hpp): what a calibration measures on a real cell.
// --verdict-out FILE keeps there whether the task's goal holds in the controller's world, the oracle a
// real cell lacks, for the dry run to set beside the perceived verdict: a JSON object (goal, holds,
// time_s) rewritten whenever the value changes and at exit. --protective-stop-after-s S is a drill: the
// arm takes a protective stop S s (its clock) after the first servo target an adapter applied.
#include <mujoco/mujoco.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <thread>

#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/frames/recording.hpp"
#include "dh/msg/cameraPubSubTypes.h"
#include "dh/rtde/cell_entities.hpp"
#include "dh/rtde/oracle_verdict.hpp"
#include "dh/rtde/servo_program.hpp"
#include "dh/rtde/simulated_ur.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/rgbd_frame_msg.hpp"
#include "dh/sim/workcell.hpp"

namespace dh {
namespace {

/// The scene's static entities as a calibration would give them: everything the workcell observes at the
/// seed's start but the free objects, which perception sees.
std::vector<EntityState> static_entities(const sim::SceneSpec& scene, std::uint64_t seed) {
  sim::Workcell cell(scene);
  cell.reset(seed, {});
  std::vector<EntityState> out;
  for (auto& e : cell.observe().entities) {
    const sim::EntitySpec* spec = scene.entity(e.name);
    if (!spec || spec->fixture()) out.push_back(std::move(e));
  }
  return out;
}

/// Answers RGB-D requests with frames of the arm's world. Renders a copy of the state taken under the
/// controller's lock, so the arm's cycle waits only for the copy; the GPU state of every camera is made
/// before the controller serves, for making it takes longer than the adapter waits for an answer.
class Cameras {
 public:
  Cameras(rtde::SimulatedController& controller, std::vector<sim::CameraSpec> cameras, std::uint32_t channel)
      : controller_(controller), cameras_(std::move(cameras)), channel_(channel) {
    gl_.make_current();
    controller_.with_arm([&](rtde::SimulatedUr& a) {
      model_ = a.mj_model();
      shown_ = sim::make_data(model_);
      mj_copyData(shown_.get(), model_, a.mj_data());
    });
    for (const auto& c : cameras_)
      rigs_[c.name] = std::make_unique<sim::CameraRig>(model_, shown_.get(), std::vector<std::string>{c.name}, c.width, c.height);
  }
  bool has(const std::string& camera) const { return spec(camera) != nullptr; }

  msg::RgbdFrame frame(const std::string& camera, const std::string& request_id) {
    msg::RgbdFrame m;
    m.channel(channel_);
    m.camera(camera);
    m.source("rtde_test_controller");
    m.step(static_cast<std::uint32_t>(sent_++));
    m.request_id(request_id);
    controller_.with_arm([&](rtde::SimulatedUr& a) { mj_copyData(shown_.get(), model_, a.mj_data()); });
    const sim::CameraSpec& c = *spec(camera);
    rigs_.at(camera)->render(0, image_, depth_);
    const sim::Pinhole K = sim::camera_pinhole(model_, camera, c.width, c.height);
    const sim::CameraPose pose = sim::camera_pose(model_, shown_.get(), camera);
    m.stamp_s(shown_->time);
    sim::set_camera(m, K, pose);
    m.rgb(image_.rgb);
    m.depth(frames::depth_le_bytes(depth_));
    return m;
  }

 private:
  const sim::CameraSpec* spec(const std::string& camera) const {
    for (const auto& c : cameras_)
      if (c.name == camera) return &c;
    return nullptr;
  }
  rtde::SimulatedController& controller_;
  std::vector<sim::CameraSpec> cameras_;
  std::uint32_t channel_;
  sim::GlContext gl_;
  const mjModel* model_ = nullptr;
  sim::DataPtr shown_;
  std::map<std::string, std::unique_ptr<sim::CameraRig>> rigs_;
  sim::Image image_;
  std::vector<std::uint16_t> depth_;
  std::uint64_t sent_ = 0;
};

int run(int argc, char** argv) {
  CLI::App app(
      "the RTDE test controller: a UR7e in MuJoCo behind RTDE on loopback (a test double, not a robot)");
  std::uint16_t port = 30004, script_port = 30002, gripper_port = 63352;
  std::string urdf = (paths::config_dir() / "robots" / "ur7e.urdf").string();
  std::vector<double> ready{0, -1.3, 1.6, -1.87, -1.5708, 0};
  std::string cell, robot = "ur7e", entities_out, verdict_out;
  unsigned task = 0, channel = 0;
  std::uint64_t seed = 0;
  double stop_after_s = 0;
  app.add_option("--port", port, "RTDE port on 127.0.0.1");
  app.add_option("--script-port", script_port, "the secondary interface's stand-in on 127.0.0.1");
  app.add_option("--gripper-port", gripper_port, "the Robotiq URCap server's stand-in on 127.0.0.1");
  app.add_option("--urdf", urdf, "the arm (6 joints), alone on a floor")->check(CLI::ExistingFile);
  app.add_option("--ready-q", ready, "the arm's joints at start (rad), alone on a floor")->delimiter(',')->expected(6);
  app.add_option("--cell", cell, "stand the arm on this benchmark cell's scene (dh tasks lists them)");
  app.add_option("--task", task, "the cell's task whose scene it is");
  app.add_option("--seed", seed, "the seed that places the scene's objects");
  app.add_option("--robot", robot, "the robot profile on the scene's mount (configs/robots; 6 joints)");
  app.add_option("--channel", channel, "the channel whose RGB-D requests it answers (with --cell)");
  app.add_option("--entities-out", entities_out,
                 "write the scene's fixtures, parts and regions for robot_adapter --entities (with --cell)");
  app.add_option("--verdict-out", verdict_out,
                 "keep whether the task's goal holds in the controller's world in this JSON file (with --cell)");
  app.add_option("--protective-stop-after-s", stop_after_s,
                 "a drill: a protective stop this long (controller time) after the first servo target an "
                 "adapter applied")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  if (!verdict_out.empty() && cell.empty()) {
    std::cerr << "--verdict-out needs --cell: the goal is the cell's task's\n";
    return 2;
  }
  auto log = make_logger("rtde_test_controller");
  install_shutdown_handlers();
  try {
    std::optional<rtde::SimulatedController> controller;
    std::vector<sim::CameraSpec> cameras;
    std::optional<rtde::OracleVerdict> verdict;
    if (cell.empty()) {
      controller.emplace(urdf, std::array<double, 6>{ready[0], ready[1], ready[2], ready[3], ready[4], ready[5]}, port,
                         script_port, gripper_port);
    } else {
      const auto suites = load_suites(paths::config_dir());
      const TaskDef& task_def = find_task(suites, cell, task);
      sim::SceneSpec scene = sim::load_task_scene(task_def, seed, robot);
      const auto rgbd_file = paths::config_dir() / "cameras.yaml";
      if (std::filesystem::exists(rgbd_file)) scene.cameras = sim::load_cameras_config(rgbd_file).for_scene(scene.name);
      cameras = scene.cameras;
      if (!entities_out.empty()) {
        std::ofstream out(entities_out);
        out << rtde::cell_entities_yaml(static_entities(scene, seed),
                                        rtde::ArmBase{scene.robot_base[0], scene.robot_base[1], scene.robot_base[2], 0});
        if (!out) throw std::runtime_error("cannot write " + entities_out);
        log->info("the scene's fixtures, parts and regions written to {}", entities_out);
      }
      controller.emplace(scene, seed, port, script_port, gripper_port);
      if (!verdict_out.empty()) {
        controller->with_arm([&](rtde::SimulatedUr& a) {
          verdict.emplace(a, scene, task_def, verdict_out);
          verdict->judge(a);
        });
        verdict->write();
      }
      log->info("the arm ({}) on {}'s mount at [{}, {}, {}], objects placed by seed {}", robot, scene.name,
                scene.robot_base[0], scene.robot_base[1], scene.robot_base[2], seed);
    }
    std::optional<Cameras> rig;
    std::optional<dds::Participant> participant;
    std::optional<dds::Writer<msg::RgbdFramePubSubType>> frames;
    std::optional<dds::Reader<msg::RgbdRequestPubSubType>> requests_in;
    EventQueue<msg::RgbdRequest> requests;
    if (!cameras.empty()) {
      // Mesa's software renderer on one thread: the other core stays with the arm's 2 ms cycle.
      setenv("LP_NUM_THREADS", "1", 0);
      rig.emplace(*controller, cameras, channel);
      participant.emplace("dh_rtde_test_controller");
      frames.emplace(*participant, topics::kRgbd, dds::Qos::Rgbd);
      requests_in.emplace(*participant, topics::kRgbdRequest, dds::Qos::RgbdRequest,
                          dds::Reader<msg::RgbdRequestPubSubType>::Callbacks{
                              [&](const msg::RgbdRequest& r, const auto&) {
                                if (r.channel() == channel && rig->has(r.camera())) requests.push(r);
                              },
                              {},
                              {}});
      log->info("answering RGB-D requests of channel={} on {} domain={}", channel, topics::kRgbd, dds::domain_id());
    }
    log->info("serving RTDE on 127.0.0.1:{}, scripts on 127.0.0.1:{} and the gripper on 127.0.0.1:{} (a test "
              "double, not a robot)",
              controller->port(), controller->script_port(), controller->gripper_port());
    auto next_log = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    std::optional<double> first_target_s;  ///< controller time of the first applied target (the drill's)
    while (!shutdown_requested()) {
      if (auto r = requests.pop(std::chrono::milliseconds(100))) {
        frames->write(rig->frame(r->camera(), r->request_id()));
        log->debug("frame of camera {} sent for request '{}'", r->camera(), r->request_id());
      }
      if (stop_after_s > 0 && controller->with_arm([&](rtde::SimulatedUr& a) {
            if (!first_target_s && std::get<std::int32_t>(a.output(rtde::ServoProgram::kAppliedRegister)) > 0)
              first_target_s = a.time();
            if (!first_target_s || a.time() < *first_target_s + stop_after_s) return false;
            a.protective_stop();
            return true;
          })) {
        log->info("drill: protective stop {} s after the first servo target", stop_after_s);
        stop_after_s = 0;
      }
      if (verdict && controller->with_arm([&](rtde::SimulatedUr& a) { return verdict->judge(a); })) verdict->write();
      if (std::chrono::steady_clock::now() < next_log) continue;
      next_log += std::chrono::seconds(1);
      const auto [running, peak] = controller->with_arm([](rtde::SimulatedUr& a) {
        const std::pair<bool, double> p{a.program_running(), a.peak_speed()};
        a.reset_peak();
        return p;
      });
      log->debug("program {} peak joint speed {:.4f} rad/s", running ? "running" : "stopped", peak);
    }
    if (verdict) {
      controller->with_arm([&](rtde::SimulatedUr& a) { verdict->judge(a); });
      verdict->write();
    }
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
