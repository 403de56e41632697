// The metal's double behind the RTDE test controller: a UR7e (configs/robots/ur7e.urdf, with the
// 2F-85-sized gripper) in MuJoCo, running our servo program's contract (servo_program.hpp) at the
// controller's 2 ms cycle. A test double, not a robot: its servoj is a speed-limited joint reference
// from damped least-squares inverse kinematics, tracked by a joint PD with gravity compensation; it
// answers for the outputs the adapter reads. Time is simulated and advanced on demand (advance_to), so a
// test reads it at any rate without a thread of its own.
//
// It stands either alone on a floor, its base at the world's origin, or on a benchmark scene's mount
// among the scene's fixtures and objects (the cell's dry run): poses in and out are in the arm's base
// frame, as a controller gives them, and the world is the scene's.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <optional>
#include <string>
#include <vector>

#include "dh/rtde/protocol.hpp"
#include "dh/rtde/robotiq_socket.hpp"
#include "dh/sim/scene.hpp"
#include "dh/rtde/test_controller.hpp"

struct mjModel_;
struct mjData_;

namespace dh::rtde {

class SimulatedUr {
 public:
  /// Loads the arm from `urdf` (6 joints, a `tcp` link) with its base at the world's origin, at `ready_q`.
  SimulatedUr(const std::filesystem::path& urdf, const std::array<double, 6>& ready_q);
  /// The scene's arm (its robot profile must have 6 joints) on the scene's mount at the profile's ready
  /// pose, the scene's entities where `seed` places them (sim::sample_placements), its cameras in the
  /// model. Throws std::invalid_argument for another arm.
  SimulatedUr(const sim::SceneSpec& scene, std::uint64_t seed);
  ~SimulatedUr();
  SimulatedUr(const SimulatedUr&) = delete;
  SimulatedUr& operator=(const SimulatedUr&) = delete;

  /// What the controller serves: the outputs below and the program's input registers.
  static ControllerModel model();

  /// A script arrived on the secondary interface: the servo program starts running; anything else is
  /// refused (the runtime state stays STOPPED) and said in last_script_error().
  void run_script(const std::string& script);
  /// Steps the cycle until simulated time reaches `t_s` (s since the controller started), each cycle
  /// reading `inputs` as the program reads its registers.
  void advance_to(double t_s, const std::map<std::string, Value>& inputs);
  /// The output named `name` now (model() lists them); throws std::invalid_argument for another.
  Value output(const std::string& name) const;

  /// The Robotiq URCap's variables (robotiq_socket.hpp) for the arm's 2F-85-sized jaw: ACT, GTO, POS, SPE
  /// and FOR are set (false for another), POS, PRE, STA, OBJ, FLT, ACT and GTO read (nullopt for another).
  /// Once active with GTO 1 the jaw goes to the requested position, no longer following the tool's
  /// digital output.
  bool robotiq_set(const std::string& var, int value);
  std::optional<int> robotiq_get(const std::string& var) const;
  /// The gripper reports fault `code` in FLT from now on (0 clears it), as a test injects one.
  void robotiq_fault(int code) { robotiq_fault_ = code; }

  /// A protective stop: the arm halts, the program stops, the safety bits say so.
  void protective_stop();
  /// The stop released on the pendant: the arm may run a program again.
  void release_protective_stop();

  double time() const { return cycles_ * kCycleS; }
  bool program_running() const { return running_; }
  /// The joint speeds of the last cycle (rad/s).
  std::array<double, 6> qd() const;
  /// The largest joint speed seen since `reset_peak()`: what "no motion after" is measured by.
  double peak_speed() const { return peak_; }
  void reset_peak() { peak_ = 0; }
  const std::string& last_script_error() const { return script_error_; }

  /// The arm's base in the world (m; the base is not turned).
  const std::array<double, 3>& base() const { return base_; }
  /// The simulation, for a camera that renders the world (under the controller's lock).
  const mjModel_* mj_model() const;
  mjData_* mj_data();

  static constexpr double kCycleS = 0.002;

 private:
  struct Sim;
  void build(const std::string& mjcf, const std::string& source, const sim::RobotSpec& spec,
             const std::vector<double>& ready_q);
  void cycle(const std::map<std::string, Value>& inputs);
  /// The tool's pose in the base frame (position, rotation vector).
  std::array<double, 6> tcp_pose() const;
  /// The joint reference that servos towards `target` (a UR pose in the base frame) this cycle.
  void servo_towards(const std::array<double, 6>& target);

  std::unique_ptr<Sim> sim_;
  std::uint64_t cycles_ = 0;
  bool running_ = false, starting_ = false, moving_ = false, protective_ = false;
  std::int32_t last_seq_ = 0, applied_ = 0, started_ = 0;
  std::array<double, 6> tcp_offset_{};
  std::array<double, 3> base_{};
  double idle_s_ = 0, peak_ = 0;
  std::array<double, 6> target_{};
  bool gripper_closed_ = false;
  bool robotiq_active_ = false, robotiq_go_ = false;
  int robotiq_request_ = 0;
  int robotiq_fault_ = 0;
  /// OBJ as a gripper reports it: once the fingers stop, the status they stopped with, kept while they stay
  /// within 3 counts of where they stopped (a held object that slips lets them move on: moving again).
  GripperObject robotiq_object_ = GripperObject::AtRequest;
  std::optional<int> robotiq_stopped_at_;
  int robotiq_position() const;
  void update_robotiq();
  std::string script_error_;
};

/// The RTDE test controller backed by a SimulatedUr in real time: a cycle thread of its own advances the
/// arm with the wall clock, as a controller's does, in slices that leave the lock to the answers, so a
/// machine too busy to simulate in real time makes the arm lag, never an answer wait. Each data package
/// is the arm's outputs at one moment; a script on the script port runs on it. Its methods may be called
/// from any thread.
class SimulatedController {
 public:
  /// Ports 0: ones the system picks.
  SimulatedController(const std::filesystem::path& urdf, const std::array<double, 6>& ready_q,
                      std::uint16_t port = 0, std::uint16_t script_port = 0, std::uint16_t gripper_port = 0);
  /// The arm on a scene's mount among its entities (SimulatedUr's second constructor).
  SimulatedController(const sim::SceneSpec& scene, std::uint64_t seed, std::uint16_t port = 0,
                      std::uint16_t script_port = 0, std::uint16_t gripper_port = 0);
  std::uint16_t port() const { return controller_.port(); }
  std::uint16_t script_port() const { return controller_.script_port(); }
  /// The Robotiq URCap's server stand-in (robotiq_socket.hpp; 63352 on a UR).
  std::uint16_t gripper_port() const { return gripper_.port(); }
  ~SimulatedController();
  TestController& controller() { return controller_; }
  /// Runs `f` on the arm under its lock.
  template <class F>
  auto with_arm(F&& f) {
    std::lock_guard lock(mutex_);
    return f(*arm_);
  }

 private:
  SimulatedController(std::unique_ptr<SimulatedUr> arm, std::uint16_t port, std::uint16_t script_port,
                      std::uint16_t gripper_port);
  /// The cycle thread: the arm advanced to the wall clock, at most kSliceS of it per hold of the lock.
  void cycle();
  static constexpr double kSliceS = 0.01;
  std::mutex mutex_;
  std::unique_ptr<SimulatedUr> arm_;
  std::chrono::steady_clock::time_point start_;
  TestController controller_;  ///< after the arm: its thread reads the arm
  RobotiqServer gripper_;      ///< the same
  std::atomic<bool> stop_{false};
  std::thread cycle_;  ///< last: started once the rest is made
};

}  // namespace dh::rtde
