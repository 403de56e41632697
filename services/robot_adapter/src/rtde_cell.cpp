#include "dh/rtde/rtde_cell.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "dh/common/robot_contract.hpp"
#include "rotation_vector.hpp"

namespace dh::rtde {
namespace {

constexpr std::uint32_t kRuntimePlaying = 2;
constexpr std::int32_t kSafetyNormal = 1, kSafetyReduced = 2;
constexpr std::uint64_t kToolOutputBits = 16;  ///< actual_digital_output_bits: tool outputs from bit 16

const std::vector<std::string>& output_names() {
  static const std::vector<std::string> n{"timestamp",
                                          "actual_q",
                                          "actual_qd",
                                          "actual_TCP_pose",
                                          "safety_mode",
                                          "safety_status_bits",
                                          "runtime_state",
                                          "actual_digital_output_bits",
                                          ServoProgram::kAppliedRegister,
                                          ServoProgram::kStartedRegister,
                                          "tcp_offset"};
  return n;
}

std::vector<std::string> input_names() {
  std::vector<std::string> n(ServoProgram::kTargetRegisters.begin(), ServoProgram::kTargetRegisters.end());
  n.push_back(ServoProgram::kSequenceRegister);
  n.push_back(ServoProgram::kGripperRegister);
  n.push_back(ServoProgram::kNonceRegister);
  return n;
}

Eigen::Isometry3d isometry_of(const std::array<double, 6>& pose) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  t.linear() = rotation_of({pose[3], pose[4], pose[5]});
  return t;
}

std::array<double, 6> pose_of(const Eigen::Isometry3d& t) {
  const Eigen::Vector3d rv = rotation_vector_of(t.linear());
  return {t.translation().x(), t.translation().y(), t.translation().z(), rv.x(), rv.y(), rv.z()};
}

/// The arm's base in the world: the configured position, turned about z by the configured yaw.
Eigen::Isometry3d world_from_base(const RtdeCellConfig& c) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(c.base_xyz[0], c.base_xyz[1], c.base_xyz[2]);
  t.linear() = Eigen::AngleAxisd(c.base_yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}

std::string safety_text(std::int32_t mode, std::uint32_t bits) {
  static const char* names[] = {"",
                                "normal",
                                "reduced",
                                "protective stop",
                                "recovery",
                                "safeguard stop",
                                "system emergency stop",
                                "robot emergency stop",
                                "violation",
                                "fault"};
  const std::string name = mode >= 1 && mode <= 9 ? names[mode] : "safety mode " + std::to_string(mode);
  char b[24];
  std::snprintf(b, sizeof b, "0x%x", bits);
  return name + " (safety_status_bits " + b + ")";
}

}  // namespace

RtdeCell::RtdeCell(RtdeCellConfig config) : config_(std::move(config)) {}

RtdeCell::~RtdeCell() { stop(); }

void RtdeCell::connect() {
  client_.connect(config_.host, config_.rtde_port, config_.timeout);
  const auto version = client_.controller_version(config_.timeout);
  if (version.major < 5) {
    client_.close();
    throw ClientError("setup: controller software " + std::to_string(version.major) + "." +
                      std::to_string(version.minor) +
                      " is older than the e-Series' 5.x this adapter is written for");
  }
  outputs_ = client_.setup_outputs(config_.output_hz, output_names(), config_.timeout);
  inputs_ = client_.setup_inputs(input_names(), config_.timeout);
  client_.start(config_.timeout);
  receive(true);
  for (int i = 0; i < 6; ++i)
    if (std::abs(state_.tcp_offset[i] - config_.tcp_offset[i]) > 1e-3) {
      client_.close();
      char b[160];
      std::snprintf(b, sizeof b, "the controller's TCP is [%.4f, %.4f, %.4f, %.3f, %.3f, %.3f]",
                    state_.tcp_offset[0], state_.tcp_offset[1], state_.tcp_offset[2], state_.tcp_offset[3],
                    state_.tcp_offset[4], state_.tcp_offset[5]);
      throw CellStopped(std::string(b) + ", not the jaw's (" + std::to_string(config_.tcp_offset[2]) +
                        " m along the flange's z): set it on the teach pendant (Installation › TCP)");
    }
  // Sequence 0 and the gripper as it is: a program still running from an earlier session holds the arm
  // and the jaw keeps what it holds. The nonce tells the new program from that one.
  seq_ = 0;
  grip_ = state_.gripper_closed;
  const std::int32_t nonce = state_.started + 1;
  send_target(state_.tcp, grip_, 0, nonce);
  send_script(config_.host, config_.script_port, servo_program_text(config_.program), config_.timeout);
  const auto deadline = std::chrono::steady_clock::now() + config_.program_start;
  while (true) {
    receive(false);
    if (state_.safety_mode != kSafetyNormal && state_.safety_mode != kSafetyReduced) {
      client_.close();
      throw CellStopped("the arm is in " + safety_text(state_.safety_mode, state_.safety_bits) +
                        ": release it on the teach pendant, then try again (the adapter connects again at "
                        "the next episode)");
    }
    if (state_.runtime_state == kRuntimePlaying && state_.started == nonce) break;
    if (std::chrono::steady_clock::now() > deadline) {
      client_.close();
      throw CellStopped("the controller did not run the " + std::string(ServoProgram::kName) +
                        " program within " + std::to_string(config_.program_start.count()) +
                        " ms (runtime_state " + std::to_string(state_.runtime_state) +
                        "): is the arm in remote control, powered on and its brakes released?");
    }
  }
  nonce_ = nonce;
  if (config_.gripper_interface != RtdeCellConfig::GripperInterface::RobotiqUrcap) return;
  try {
    gripper_.connect(config_.host, config_.gripper_port, config_.timeout);
    gripper_.activate(config_.gripper_force, config_.program_start);
    grip_ = gripper_.get("PRE", config_.timeout) > 127;  // the jaw keeps what it holds
    read_gripper();
  } catch (const GripperError& e) {
    stop();
    client_.close();
    gripper_.close();
    throw CellStopped(std::string(e.what()) + "; the arm is stopped");
  }
}

void RtdeCell::read_gripper() {
  // A gripper in fault does not do what it is told: the step (or the connect) ends with the arm stopped.
  if (const int fault = gripper_.get("FLT", config_.timeout); fault != 0) {
    char code[8];
    std::snprintf(code, sizeof code, "0x%02X", fault);
    throw GripperError("gripper: fault " + std::string(code) + ", " + robotiq_fault_text(fault));
  }
  state_.gripper_position = gripper_.get("POS", config_.timeout);
  state_.gripper_object = gripper_.get("OBJ", config_.timeout);
}

void RtdeCell::stop() noexcept {
  if (!client_.connected() || !inputs_) return;
  try {
    send_target(state_.tcp, grip_, 0, nonce_);
  } catch (const std::exception&) {
    // The link is gone: the program's watchdog stops the arm.
  }
}

void RtdeCell::receive(bool latest) {
  const int position = state_.gripper_position, object = state_.gripper_object;
  const auto v = latest ? client_.receive_latest(*outputs_, config_.timeout)
                        : client_.receive(*outputs_, config_.timeout);
  State s;
  s.time = std::get<double>(v[0]);
  s.q = std::get<std::array<double, 6>>(v[1]);
  s.qd = std::get<std::array<double, 6>>(v[2]);
  s.tcp = std::get<std::array<double, 6>>(v[3]);
  s.safety_mode = std::get<std::int32_t>(v[4]);
  s.safety_bits = std::get<std::uint32_t>(v[5]);
  s.runtime_state = std::get<std::uint32_t>(v[6]);
  s.gripper_closed =
      (std::get<std::uint64_t>(v[7]) >> (kToolOutputBits + config_.program.gripper_output)) & 1u;
  s.applied = std::get<std::int32_t>(v[8]);
  s.started = std::get<std::int32_t>(v[9]);
  s.tcp_offset = std::get<std::array<double, 6>>(v[10]);
  s.gripper_position = position;  // read from the gripper, not the controller's outputs
  s.gripper_object = object;
  state_ = s;
}

void RtdeCell::check_running(const char* when) {
  std::string why;
  if (state_.safety_mode != kSafetyNormal && state_.safety_mode != kSafetyReduced)
    why = "the controller reports " + safety_text(state_.safety_mode, state_.safety_bits);
  else if (state_.runtime_state != kRuntimePlaying)
    why = "the " + std::string(ServoProgram::kName) + " program is no longer running (runtime_state " +
          std::to_string(state_.runtime_state) + ")";
  if (why.empty()) return;
  // The session ends with the episode: the next one connects again and starts the program anew.
  stop();
  client_.close();
  throw CellStopped(std::string(when) + ": " + why + " at its t " + std::to_string(state_.time) +
                    " s; the arm is stopped");
}

void RtdeCell::send_target(const std::array<double, 6>& base_pose, bool grip, std::int32_t seq,
                           std::int32_t nonce) {
  std::vector<Value> values(base_pose.begin(), base_pose.end());
  values.emplace_back(seq);
  values.emplace_back(std::int32_t{grip ? 1 : 0});
  values.emplace_back(nonce);
  client_.send(*inputs_, values, config_.timeout);
}

std::vector<sim::StepEvent> RtdeCell::step(const std::array<double, 7>& action) {
  std::vector<sim::StepEvent> events;
  std::array<double, 7> a = action;
  if (auto why = sim::clamp_action(a)) events.push_back({sim::StepEvent::ActionClamped, std::move(*why)});
  try {
    receive(true);  // the newest outputs: they streamed on while the step's action was decided
    check_running("before the step");
    // World frame: the contract's offsets are world-frame.
    const Eigen::Isometry3d base = world_from_base(config_);
    UrPose target = servo_target(pose_of(base * isometry_of(state_.tcp)), a);
    std::array<double, 3> xyz{target[0], target[1], target[2]};
    if (sim::clamp_to_workspace(xyz, config_.limits))
      events.push_back({sim::StepEvent::WorkspaceClamp, "target clamped into the workspace box"});
    std::copy(xyz.begin(), xyz.end(), target.begin());
    const bool was_gripping = grip_;
    grip_ = a[6] > 0;
    send_target(pose_of(base.inverse() * isometry_of(target)), grip_, ++seq_, nonce_);
    const bool robotiq = config_.gripper_interface == RtdeCellConfig::GripperInterface::RobotiqUrcap;
    if (robotiq && grip_ != was_gripping) gripper_.set({{"POS", grip_ ? 255 : 0}}, config_.timeout);
    // One control step of the controller's clock, every output checked.
    const double until = state_.time + robot::kControlPeriodS - 1e-9;
    bool held = false;
    do {
      receive(false);
      check_running("during the step");
      std::array<double, 7> qd{};
      std::copy(state_.qd.begin(), state_.qd.end(), qd.begin());
      const auto v = sim::check_joint_speeds(qd, config_.limits);
      if (!v.ok && !held) {
        held = true;
        send_target(state_.tcp, grip_, 0, nonce_);
        events.push_back(
            {sim::StepEvent::SafetyHold, v.reason + "; the arm is held for the rest of the step"});
      }
    } while (state_.time < until);
    if (robotiq) read_gripper();
  } catch (const GripperError& e) {
    stop();
    gripper_.close();  // the next session connects to it again
    throw CellStopped(std::string(e.what()) + "; the arm is stopped");
  } catch (const ClientError& e) {
    throw CellStopped(std::string("the link to the controller was lost (") + e.what() +
                      "); the program's watchdog stops the arm within " +
                      std::to_string(config_.program.watchdog_s) + " s");
  }
  return events;
}

Observation RtdeCell::observe() const {
  Observation o;
  const Eigen::Isometry3d tool = world_from_base(config_) * isometry_of(state_.tcp);
  const Eigen::Vector3d p = tool.translation();
  const Eigen::Quaterniond q(tool.linear());
  o.ee_p = {p.x(), p.y(), p.z()};
  o.ee_q = {q.w(), q.x(), q.y(), q.z()};
  std::copy(state_.q.begin(), state_.q.end(), o.q.begin());
  std::copy(state_.qd.begin(), state_.qd.end(), o.dq.begin());
  if (state_.gripper_position >= 0) {
    // A Robotiq gripper reports its fingers' position, and whether they stopped on an object while closing:
    // then both pads touch it.
    o.gripper_opening = robotiq_gap(state_.gripper_position, config_.robotiq_range, config_.gripper_stroke_m);
    o.contact_left = o.contact_right = state_.gripper_object == static_cast<int>(GripperObject::StoppedClosing);
  } else {
    // A gripper on a digital output reports its command, not its gap or contacts.
    o.gripper_opening = state_.gripper_closed ? 0.0 : config_.gripper_stroke_m;
  }
  o.gripper = config_.gripper;
  o.base_p = config_.base_xyz;
  o.entities = config_.entities;
  return o;
}

}  // namespace dh::rtde
