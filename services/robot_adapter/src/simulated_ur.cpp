#include "dh/rtde/simulated_ur.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dh/rtde/servo_program.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/placing.hpp"
#include "dh/sim/robot_model.hpp"
#include "rotation_vector.hpp"

namespace dh::rtde {
namespace {

// The joint PD under the reference: stiff on the three big joints, soft on the wrists (critically
// damped on the model's inertias with its 0.1 armature).
constexpr std::array<double, 6> kKp{4000, 4000, 3000, 500, 500, 300};
constexpr std::array<double, 6> kKd{150, 150, 120, 15, 15, 10};
constexpr double kIkDamping = 0.05;  ///< damped least squares' λ
constexpr int kIkIterations = 4;     ///< per cycle, from the last solution
constexpr double kGripperOpen = 0.0425;

enum RuntimeState : std::uint32_t { kStopped = 1, kPlaying = 2 };
constexpr std::int32_t kRobotRunning = 7;
constexpr std::int32_t kSafetyNormal = 1, kSafetyProtectiveStop = 3;
constexpr std::uint32_t kBitNormal = 1u << 0, kBitProtectiveStopped = 1u << 2;
constexpr std::uint64_t kToolOutput0Bit = 1ull << 16;  ///< tool digital outputs are bits 16–17

}  // namespace

struct SimulatedUr::Sim {
  sim::ModelPtr model;
  sim::DataPtr data, ik;
  std::array<int, 6> qpos{}, dof{}, motor{};
  int tcp = -1, gripper = -1;
  int finger_qpos = -1, finger_dof = -1;  ///< the jaw's driven finger
  std::array<double, 6> q_ref{}, dq_ref{};
};

SimulatedUr::SimulatedUr(const std::filesystem::path& urdf, const std::array<double, 6>& ready_q)
    : sim_(std::make_unique<Sim>()) {
  const sim::RobotSpec spec = sim::load_robot(urdf);
  const double origin[3] = {0, 0, 0};
  const auto f = sim::robot_mjcf(spec, origin, 1.5);
  build("<mujoco model=\"simulated_ur\"><compiler angle=\"radian\"/><option timestep=\"" + std::to_string(kCycleS) +
            "\"/><worldbody><geom name=\"floor\" type=\"plane\" size=\"2 2 0.1\"/>" + f.body +
            "</worldbody><actuator>" + f.actuators + "</actuator><equality>" + f.equalities + "</equality></mujoco>",
        urdf.string(), spec, {ready_q.begin(), ready_q.end()});
}

SimulatedUr::SimulatedUr(const sim::SceneSpec& scene, std::uint64_t seed) : sim_(std::make_unique<Sim>()) {
  base_ = scene.robot_base;
  const auto placements = sim::sample_placements(scene, seed);
  build(sim::scene_mjcf(scene, placements), scene.file.string(), scene.robot, scene.ready_q);
  sim::place_entities(sim_->model.get(), sim_->data.get(), scene, placements);
  mj_forward(sim_->model.get(), sim_->data.get());
}

void SimulatedUr::build(const std::string& mjcf, const std::string& source, const sim::RobotSpec& spec,
                        const std::vector<double>& ready_q) {
  if (spec.arm.size() != 6 || ready_q.size() != 6)
    throw std::invalid_argument(source + ": the simulated UR needs a 6-joint arm, found " +
                                std::to_string(spec.arm.size()));
  sim_->model = sim::compile_model(mjcf, source);
  mjModel* m = sim_->model.get();
  // The program's contract is per 2 ms cycle: one physics step each.
  if (std::abs(m->opt.timestep - kCycleS) > 1e-12)
    throw std::invalid_argument(source + ": the simulated UR steps at " + std::to_string(kCycleS) +
                                " s, the model at " + std::to_string(m->opt.timestep));
  sim_->data = sim::make_data(m);
  sim_->ik = sim::make_data(m);
  for (int i = 0; i < 6; ++i) {
    const int j = mj_name2id(m, mjOBJ_JOINT, spec.arm[i].name.c_str());
    sim_->qpos[i] = m->jnt_qposadr[j];
    sim_->dof[i] = m->jnt_dofadr[j];
    sim_->motor[i] = mj_name2id(m, mjOBJ_ACTUATOR, (spec.arm[i].name + "_motor").c_str());
    sim_->data->qpos[sim_->qpos[i]] = ready_q[i];
    sim_->q_ref[i] = ready_q[i];
  }
  // The jaw starts open: closed, the pads start in contact with each other.
  for (const auto& finger : spec.fingers)
    sim_->data->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, finger.name.c_str())]] = kGripperOpen;
  sim_->tcp = mj_name2id(m, mjOBJ_SITE, "tcp");
  // The TCP as the pendant would hold it: the tool site's place in the flange's frame (the hand's).
  const int tool_body = m->site_bodyid[sim_->tcp];
  for (int i = 0; i < 3; ++i)
    tcp_offset_[i] = m->body_pos[3 * tool_body + i] + m->site_pos[3 * sim_->tcp + i];
  sim_->gripper = mj_name2id(m, mjOBJ_ACTUATOR, "gripper");
  const int finger = mj_name2id(m, mjOBJ_JOINT, spec.fingers.front().name.c_str());
  sim_->finger_qpos = m->jnt_qposadr[finger];
  sim_->finger_dof = m->jnt_dofadr[finger];
  sim_->data->ctrl[sim_->gripper] = kGripperOpen;
  mj_forward(m, sim_->data.get());
  target_ = tcp_pose();
}

SimulatedUr::~SimulatedUr() = default;

ControllerModel SimulatedUr::model() {
  ControllerModel c;
  for (const char* n : {"actual_q", "target_q", "actual_qd", "actual_TCP_pose", "target_TCP_pose"})
    c.outputs[n] = FieldType::Vector6d;
  c.outputs["timestamp"] = FieldType::Double;
  c.outputs["robot_mode"] = c.outputs["safety_mode"] = FieldType::Int32;
  c.outputs["safety_status_bits"] = c.outputs["runtime_state"] = c.outputs["robot_status_bits"] =
      FieldType::Uint32;
  c.outputs["actual_digital_output_bits"] = FieldType::Uint64;
  c.outputs[ServoProgram::kAppliedRegister] = c.outputs[ServoProgram::kStartedRegister] = FieldType::Int32;
  c.outputs["tcp_offset"] = FieldType::Vector6d;
  for (const char* n : ServoProgram::kTargetRegisters) c.inputs[n] = FieldType::Double;
  c.inputs[ServoProgram::kSequenceRegister] = c.inputs[ServoProgram::kGripperRegister] =
      c.inputs[ServoProgram::kNonceRegister] = FieldType::Int32;
  return c;
}

void SimulatedUr::run_script(const std::string& script) {
  if (!is_servo_program(script)) {
    script_error_ = "not the " + std::string(ServoProgram::kName) + " program (version " +
                    std::to_string(ServoProgram::kVersion) + "): refused";
    return;
  }
  if (protective_) {
    script_error_ = "a protective stop is active: the program cannot start until it is released";
    return;
  }
  script_error_.clear();
  running_ = starting_ = true;
  moving_ = false;
  applied_ = 0;
  last_seq_ = 0;
}

bool SimulatedUr::robotiq_set(const std::string& var, int value) {
  if (var == "ACT") robotiq_active_ = value == 1;
  else if (var == "GTO") robotiq_go_ = value == 1;
  else if (var == "POS") {
    robotiq_request_ = std::clamp(value, 0, 255);
    robotiq_stopped_at_.reset();
    robotiq_object_ = GripperObject::Moving;
  }
  else if (var != "SPE" && var != "FOR") return false;  // the double's jaw moves at one speed and force
  return true;
}

int SimulatedUr::robotiq_position() const {
  const RobotiqRange range;
  const double gap = sim_->data->qpos[sim_->finger_qpos];  // each finger's travel from shut, m
  return static_cast<int>(std::lround(range.closed - (range.closed - range.open) * gap / kGripperOpen));
}

void SimulatedUr::update_robotiq() {
  if (!robotiq_active_ || !robotiq_go_) return;
  const int position = robotiq_position();
  if (robotiq_stopped_at_ && std::abs(position - *robotiq_stopped_at_) <= 3) return;
  robotiq_stopped_at_.reset();
  // Moving faster than 2 mm/s; else at the request (within 3 counts) or stopped short of it by an object.
  if (std::abs(sim_->data->qvel[sim_->finger_dof]) > 0.002) {
    robotiq_object_ = GripperObject::Moving;
    return;
  }
  const RobotiqRange range;
  const int aim = std::clamp(robotiq_request_, range.open, range.closed);
  robotiq_object_ = std::abs(position - aim) <= 3 ? GripperObject::AtRequest
                    : aim > position             ? GripperObject::StoppedClosing
                                                 : GripperObject::StoppedOpening;
  robotiq_stopped_at_ = position;
}

std::optional<int> SimulatedUr::robotiq_get(const std::string& var) const {
  if (var == "POS") return robotiq_position();
  if (var == "PRE") return robotiq_request_;
  if (var == "ACT") return robotiq_active_ ? 1 : 0;
  if (var == "GTO") return robotiq_go_ ? 1 : 0;
  if (var == "STA") return robotiq_active_ ? 3 : 0;
  if (var == "OBJ") return static_cast<int>(robotiq_object_);
  if (var == "FLT") return robotiq_fault_;
  return std::nullopt;
}

void SimulatedUr::protective_stop() {
  protective_ = true;
  running_ = moving_ = false;
  applied_ = 0;
}

void SimulatedUr::release_protective_stop() { protective_ = false; }

void SimulatedUr::advance_to(double t_s, const std::map<std::string, Value>& inputs) {
  while ((cycles_ + 1) * kCycleS <= t_s + 1e-12) cycle(inputs);
}

void SimulatedUr::cycle(const std::map<std::string, Value>& inputs) {
  const auto int_input = [&](const char* name) {
    const auto it = inputs.find(name);
    return it == inputs.end() ? 0 : std::get<std::int32_t>(it->second);
  };
  if (starting_) {  // the program's first lines
    started_ = int_input(ServoProgram::kNonceRegister);
    starting_ = false;
  }
  if (running_) {
    // What the program does in one cycle (servo_program.cpp).
    const std::int32_t seq = int_input(ServoProgram::kSequenceRegister);
    if (seq > 0 && seq != last_seq_) {
      for (std::size_t i = 0; i < 6; ++i) {
        const auto it = inputs.find(ServoProgram::kTargetRegisters[i]);
        target_[i] = it == inputs.end() ? 0.0 : std::get<double>(it->second);
      }
      last_seq_ = applied_ = seq;
      idle_s_ = 0;
      moving_ = true;
    }
    gripper_closed_ = int_input(ServoProgram::kGripperRegister) == 1;
    if (moving_ && (seq == 0 || idle_s_ >= ServoProgram{}.watchdog_s)) {
      moving_ = false;
      applied_ = 0;
    }
    if (moving_) {
      servo_towards(target_);
      idle_s_ += kCycleS;
    }
  }
  mjModel* m = sim_->model.get();
  mjData* d = sim_->data.get();
  if (!moving_) sim_->dq_ref.fill(0);  // stopj: the reference stands; the PD brings the arm to rest on it
  for (int i = 0; i < 6; ++i) {
    const double tau = kKp[i] * (sim_->q_ref[i] - d->qpos[sim_->qpos[i]]) +
                       kKd[i] * (sim_->dq_ref[i] - d->qvel[sim_->dof[i]]) + d->qfrc_bias[sim_->dof[i]];
    const double limit = m->actuator_ctrlrange[2 * sim_->motor[i] + 1];
    d->ctrl[sim_->motor[i]] = std::clamp(tau, -limit, limit);
  }
  if (robotiq_active_ && robotiq_go_) {
    const RobotiqRange range;
    d->ctrl[sim_->gripper] =
        kGripperOpen * std::clamp(static_cast<double>(range.closed - robotiq_request_) / (range.closed - range.open), 0.0, 1.0);
  } else {
    d->ctrl[sim_->gripper] = gripper_closed_ ? 0.0 : kGripperOpen;
  }
  mj_step(m, d);
  ++cycles_;
  update_robotiq();
  for (double v : qd()) peak_ = std::max(peak_, std::abs(v));
}

void SimulatedUr::servo_towards(const std::array<double, 6>& target) {
  mjModel* m = sim_->model.get();
  mjData* k = sim_->ik.get();
  // Inverse kinematics near the reference (get_inverse_kin with qnear), damped least squares.
  std::copy_n(sim_->data->qpos, m->nq, k->qpos);
  for (int i = 0; i < 6; ++i) k->qpos[sim_->qpos[i]] = sim_->q_ref[i];
  const Eigen::Vector3d p_goal(target[0] + base_[0], target[1] + base_[1], target[2] + base_[2]);
  const Eigen::Matrix3d r_goal = rotation_of({target[3], target[4], target[5]});
  std::vector<double> jp(3 * m->nv), jr(3 * m->nv);
  for (int it = 0; it < kIkIterations; ++it) {
    mj_kinematics(m, k);
    mj_comPos(m, k);
    Eigen::Matrix<double, 6, 1> err;
    err.head<3>() = p_goal - Eigen::Vector3d(k->site_xpos[3 * sim_->tcp], k->site_xpos[3 * sim_->tcp + 1],
                                             k->site_xpos[3 * sim_->tcp + 2]);
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = k->site_xmat[9 * sim_->tcp + 3 * i + j];
    const Eigen::AngleAxisd e(r_goal * r.transpose());
    err.tail<3>() = e.angle() * e.axis();
    mj_jacSite(m, k, jp.data(), jr.data(), sim_->tcp);
    Eigen::Matrix<double, 6, 6> j;
    for (int c = 0; c < 6; ++c)
      for (int row = 0; row < 3; ++row) {
        j(row, c) = jp[row * m->nv + sim_->dof[c]];
        j(row + 3, c) = jr[row * m->nv + sim_->dof[c]];
      }
    const Eigen::Matrix<double, 6, 1> dq =
        j.transpose() *
        (j * j.transpose() + kIkDamping * kIkDamping * Eigen::Matrix<double, 6, 6>::Identity())
            .ldlt()
            .solve(err);
    for (int i = 0; i < 6; ++i) k->qpos[sim_->qpos[i]] += dq[i];
  }
  // The program steps its reference towards the solution within its joint speed; servoj follows it at the
  // gain's share per cycle.
  const ServoProgram program;
  const double share = std::min(1.0, program.timing.gain * program.timing.t_s);
  const double max_step = program.joint_speed * kCycleS;
  for (int i = 0; i < 6; ++i) {
    const double step = std::clamp(share * (k->qpos[sim_->qpos[i]] - sim_->q_ref[i]), -max_step, max_step);
    sim_->q_ref[i] += step;
    sim_->dq_ref[i] = step / kCycleS;
  }
}

std::array<double, 6> SimulatedUr::tcp_pose() const {
  const mjData* d = sim_->data.get();
  const int t = sim_->tcp;
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = d->site_xmat[9 * t + 3 * i + j];
  const Eigen::Vector3d rv = rotation_vector_of(r);
  return {d->site_xpos[3 * t] - base_[0], d->site_xpos[3 * t + 1] - base_[1], d->site_xpos[3 * t + 2] - base_[2],
          rv.x(), rv.y(), rv.z()};
}

const mjModel* SimulatedUr::mj_model() const { return sim_->model.get(); }
mjData* SimulatedUr::mj_data() { return sim_->data.get(); }

std::array<double, 6> SimulatedUr::qd() const {
  std::array<double, 6> v{};
  for (int i = 0; i < 6; ++i) v[i] = sim_->data->qvel[sim_->dof[i]];
  return v;
}

Value SimulatedUr::output(const std::string& name) const {
  const mjData* d = sim_->data.get();
  std::array<double, 6> q{};
  for (int i = 0; i < 6; ++i) q[i] = d->qpos[sim_->qpos[i]];
  if (name == "timestamp") return time();
  if (name == "actual_q") return q;
  if (name == "target_q") return sim_->q_ref;
  if (name == "actual_qd") return qd();
  if (name == "actual_TCP_pose") return tcp_pose();
  if (name == "target_TCP_pose") return target_;
  if (name == "robot_mode") return kRobotRunning;
  if (name == "safety_mode") return protective_ ? kSafetyProtectiveStop : kSafetyNormal;
  if (name == "safety_status_bits") return protective_ ? kBitProtectiveStopped : kBitNormal;
  if (name == "runtime_state") return static_cast<std::uint32_t>(running_ ? kPlaying : kStopped);
  if (name == "robot_status_bits") return static_cast<std::uint32_t>(1u | (running_ ? 2u : 0u));
  if (name == "actual_digital_output_bits") return gripper_closed_ ? kToolOutput0Bit : std::uint64_t{0};
  if (name == ServoProgram::kAppliedRegister) return applied_;
  if (name == ServoProgram::kStartedRegister) return started_;
  if (name == "tcp_offset") return tcp_offset_;
  throw std::invalid_argument("the simulated UR has no output '" + name + "'");
}

SimulatedController::SimulatedController(const std::filesystem::path& urdf,
                                         const std::array<double, 6>& ready_q, std::uint16_t port,
                                         std::uint16_t script_port, std::uint16_t gripper_port)
    : SimulatedController(std::make_unique<SimulatedUr>(urdf, ready_q), port, script_port, gripper_port) {}

SimulatedController::SimulatedController(const sim::SceneSpec& scene, std::uint64_t seed, std::uint16_t port,
                                         std::uint16_t script_port, std::uint16_t gripper_port)
    : SimulatedController(std::make_unique<SimulatedUr>(scene, seed), port, script_port, gripper_port) {}

SimulatedController::SimulatedController(std::unique_ptr<SimulatedUr> arm, std::uint16_t port,
                                         std::uint16_t script_port, std::uint16_t gripper_port)
    : arm_(std::move(arm)),
      start_(std::chrono::steady_clock::now()),
      controller_(
          SimulatedUr::model(),
          [this](const std::vector<std::string>& names) {
            std::lock_guard lock(mutex_);
            std::vector<Value> values;
            for (const auto& name : names) values.push_back(arm_->output(name));
            return values;
          },
          [this](const std::string& script) {
            std::lock_guard lock(mutex_);
            arm_->run_script(script);
          },
          port, script_port),
      gripper_(
          [this](const std::string& var, int value) {
            std::lock_guard lock(mutex_);
            return arm_->robotiq_set(var, value);
          },
          [this](const std::string& var) {
            std::lock_guard lock(mutex_);
            return arm_->robotiq_get(var);
          },
          gripper_port),
      cycle_([this] { cycle(); }) {}

SimulatedController::~SimulatedController() {
  stop_ = true;
  cycle_.join();
}

void SimulatedController::cycle() {
  while (!stop_) {
    bool caught_up = false;
    {
      std::lock_guard lock(mutex_);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
      arm_->advance_to(std::min(wall, arm_->time() + kSliceS), controller_.inputs());
      caught_up = wall - arm_->time() < SimulatedUr::kCycleS;
    }
    if (caught_up) std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
}

}  // namespace dh::rtde
