// The metal's double behind the RTDE test controller: a UR7e (configs/robots/ur7e.urdf, with the
// 2F-85-sized gripper) in MuJoCo, running our servo program's contract (servo_program.hpp) at the
// controller's 2 ms cycle. A test double, not a robot: its servoj is a speed-limited joint reference
// from damped least-squares inverse kinematics, tracked by a joint PD with gravity compensation; it
// answers for the outputs the adapter reads. Time is simulated and advanced on demand (advance_to), so a
// test reads it at any rate without a thread of its own.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "dh/rtde/protocol.hpp"
#include "dh/rtde/test_controller.hpp"

namespace dh::rtde {

class SimulatedUr {
 public:
  /// Loads the arm from `urdf` (6 joints, a `tcp` link) with its base at the world's origin, at `ready_q`.
  SimulatedUr(const std::filesystem::path& urdf, const std::array<double, 6>& ready_q);
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

  static constexpr double kCycleS = 0.002;

 private:
  struct Sim;
  void cycle(const std::map<std::string, Value>& inputs);
  /// The joint reference that servos towards `target` (a UR pose) this cycle.
  void servo_towards(const std::array<double, 6>& target);

  std::unique_ptr<Sim> sim_;
  std::uint64_t cycles_ = 0;
  bool running_ = false, starting_ = false, moving_ = false, protective_ = false;
  std::int32_t last_seq_ = 0, applied_ = 0, started_ = 0;
  std::array<double, 6> tcp_offset_{};
  double idle_s_ = 0, peak_ = 0;
  std::array<double, 6> target_{};
  bool gripper_closed_ = false;
  std::string script_error_;
};

/// The RTDE test controller backed by a SimulatedUr in real time: each data package is the arm's outputs
/// at one moment, after it is advanced to the wall clock; a script on the script port runs on it. Its methods may be called
/// from any thread.
class SimulatedController {
 public:
  /// Ports 0: ones the system picks.
  SimulatedController(const std::filesystem::path& urdf, const std::array<double, 6>& ready_q,
                      std::uint16_t port = 0, std::uint16_t script_port = 0);
  std::uint16_t port() const { return controller_.port(); }
  std::uint16_t script_port() const { return controller_.script_port(); }
  TestController& controller() { return controller_; }
  /// Runs `f` on the arm, advanced to now, under its lock.
  template <class F>
  auto with_arm(F&& f) {
    std::lock_guard lock(mutex_);
    advance();
    return f(arm_);
  }

 private:
  void advance();
  std::mutex mutex_;
  SimulatedUr arm_;
  std::chrono::steady_clock::time_point start_;
  TestController controller_;  ///< last: its thread reads the arm
};

}  // namespace dh::rtde
