// A UR arm over RTDE as the seam's cell (dh/sim/seam_cell.hpp): the seam core admits an action, and this
// turns it into servo targets for the controller's program (servo_program.hpp) for one 50 ms control
// step, watching the controller's outputs meanwhile.
//
// In one step:
// - the target is servo_target() of the measured TCP pose (servo.hpp), in the world frame, clamped into
//   the workspace box (a WorkspaceClamp correction), then put into the arm's base frame and written with
//   the next sequence number and the gripper command (a[6] > 0 closes);
// - outputs are read until the controller's clock has moved on by a control step; every one is checked
//   against the joint-speed envelope (2 rad/s): over it, the program is told to stop (sequence 0) and the
//   step ends as a SafetyHold, the arm held for the rest of it;
// - a protective stop (or any safety stop) in the outputs, the program no longer running, or the link
//   lost: the program is told to stop where the link allows, the session is closed (the next episode
//   connects again and restarts the program), and step() throws CellStopped with what the controller
//   said. If the link itself is gone, the program's watchdog stops the arm within 0.1 s.
// A step starts from the newest outputs: they stream on while the next action is decided.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dh/rtde/client.hpp"
#include "dh/rtde/robotiq_socket.hpp"
#include "dh/rtde/servo_program.hpp"
#include "dh/sim/safety.hpp"
#include "dh/sim/seam_cell.hpp"

namespace dh::rtde {

struct RtdeCellConfig {
  std::string host = "127.0.0.1";
  std::uint16_t rtde_port = 30004;
  std::uint16_t script_port = 30002;
  /// The output recipe's rate: every package is checked against the envelope, and a 20 Hz step ends
  /// within one package period of its 50 ms.
  double output_hz = 250;
  std::chrono::milliseconds timeout{500};         ///< per exchange with the controller
  std::chrono::milliseconds program_start{2000};  ///< the program must be running within this
  /// The arm's base in the world (table top at z 0): position and yaw (the base stands upright).
  std::array<double, 3> base_xyz{};
  double base_yaw = 0;
  sim::SafetyLimits limits;  ///< the envelope and the workspace box, world frame
  ServoProgram program;
  double gripper_stroke_m = 0.085;  ///< the gap a fully open jaw reports
  /// How the jaw is driven and read: a tool digital output, which reports only its command, or a Robotiq
  /// gripper through its URCap's socket (robotiq_socket.hpp), which reports its fingers' position and
  /// whether they stopped on an object (the observation's gap and contacts).
  enum class GripperInterface { DigitalOutput, RobotiqUrcap };
  GripperInterface gripper_interface = GripperInterface::DigitalOutput;
  std::uint16_t gripper_port = 63352;  ///< the URCap's server on the controller
  RobotiqRange robotiq_range;          ///< the fingers' measured open and touching positions
  int gripper_force = 100;             ///< the Robotiq force register, 0..255
  /// The jaw's shape about the TCP, as skills plan contact with it: the 2F-85's (configs/robots/ur7e.yaml
  /// declares the same; a test holds them equal): pads 37.5 mm tall centred on the TCP, 22 mm wide, 8 mm
  /// thick; the coupling and body 0.1415 m up to the flange.
  robot::Gripper gripper{0.01875, 0.011, 0.008, 0.1415};
  /// The TCP the controller must be set to (x, y, z, rotation vector, flange frame): the jaw's pads' centre.
  std::array<double, 6> tcp_offset{0, 0, 0.1415, 0, 0, 0};
  std::vector<EntityState>
      entities;  ///< the cell's static entities (cell_entities.hpp), in every observation
};

/// The cell cannot go on: a protective or other safety stop, the program not running, the link lost.
struct CellStopped : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class RtdeCell final : public sim::SeamCell {
 public:
  explicit RtdeCell(RtdeCellConfig config);
  ~RtdeCell() override;

  /// Connects, sets up the recipes, checks the controller's TCP, starts the program and waits until it
  /// runs (it echoes this session's nonce) with the arm in normal safety. Throws ClientError or
  /// CellStopped naming what failed and what to do; the session is then closed.
  void connect();
  /// Tells the program to stop the arm (sequence 0); never throws (the watchdog stops it on a lost link).
  void stop() noexcept;

  std::vector<sim::StepEvent> step(const std::array<double, 7>& action) override;
  Observation observe() const override;

  /// Outputs, as read last.
  struct State {
    double time = 0;                         ///< the controller's clock (s)
    std::array<double, 6> q{}, qd{}, tcp{};  ///< tcp: base frame, x y z + rotation vector
    std::int32_t safety_mode = 0, applied = 0, started = 0;
    std::array<double, 6> tcp_offset{};
    std::uint32_t safety_bits = 0, runtime_state = 0;
    bool gripper_closed = false;  ///< the tool digital output the program drives
    /// A Robotiq gripper's fingers: measured position and object status (robotiq_socket.hpp); -1 without one.
    int gripper_position = -1, gripper_object = -1;
  };
  const State& state() const { return state_; }
  bool connected() const { return client_.connected(); }

 private:
  /// The next output package (`latest`: the newest one queued), decoded.
  void receive(bool latest);
  /// CellStopped when the controller reports a stop or the program is not running; the session is closed.
  void check_running(const char* when);
  void send_target(const std::array<double, 6>& base_pose, bool grip, std::int32_t seq, std::int32_t nonce);
  /// The Robotiq gripper's position and object status into the state (with a Robotiq gripper).
  void read_gripper();

  RtdeCellConfig config_;
  Client client_;
  RobotiqClient gripper_;
  std::optional<Recipe> outputs_, inputs_;
  State state_;
  std::int32_t seq_ = 0, nonce_ = 0;
  bool grip_ = false;
};

}  // namespace dh::rtde
