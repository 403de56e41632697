#include "dh/sim/workcell.hpp"

#include "dh/common/robot_contract.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "dh/common/digest.hpp"
#include "dh/common/geometry.hpp"
#include "dh/sim/model.hpp"

namespace dh::sim {

namespace {
// Joint-space PD gains of the tracking controller (per arm joint, base to tip).
constexpr std::array<double, 7> kKp{900, 900, 700, 700, 300, 200, 100};
constexpr std::array<double, 7> kKd{80, 80, 60, 60, 20, 15, 8};
constexpr double kIkDamping = 0.05;
constexpr double kNullGain = 0.1;
// The controller's own speed limit sits below the seam's envelope, so the check only trips on faults.
constexpr double kRefSpeedFraction = 0.9;
}  // namespace

struct Workcell::Ids {
  std::array<int, 7> arm_qpos{}, arm_dof{}, arm_act{};
  std::vector<int> finger_qpos;
  int gripper_act = -1;
  int tcp_site = -1;
  int finger_left_body = -1, finger_right_body = -1;
  std::vector<int> object_body, object_qpos;  ///< free objects, in scene order
  std::vector<std::size_t> object_entity;     ///< index into scene.entities
  std::vector<int> fixture_body;
  std::vector<std::size_t> fixture_entity;
  struct Part {
    std::string name, kind;
    int body = -1, grip_site = -1, qpos = -1;
    std::array<double, 3> grip_half{};
  };
  std::vector<Part> parts;                    ///< fixtures' articulated parts, in scene order
  std::vector<int> region_site;               ///< every other site: table regions and asset regions
  std::vector<double> q_lower, q_upper;
  std::vector<double> effort;
};

Workcell::Workcell(SceneSpec scene) : scene_(std::move(scene)) {
  limits_.workspace_min = scene_.workspace_min;
  limits_.workspace_max = scene_.workspace_max;
  // The envelope: the paper's 2 rad/s, never above any joint's own URDF limit.
  for (const auto& j : scene_.robot.arm) limits_.joint_speed = std::min(limits_.joint_speed, j.velocity);

  std::vector<Placement> nominal;
  for (const auto& e : scene_.entities) nominal.push_back({e.name, e.nominal_xy[0], e.nominal_xy[1], e.yaw});
  m_ = compile_model(scene_mjcf(scene_, nominal), scene_.file.string()).release();
  d_ = mj_makeData(m_);
  ik_ = mj_makeData(m_);
  // The hash is of the model without the RGB-D cameras a simulator worker adds (configs/cameras.yaml):
  // they render, they do not move anything, and an in-process run has none.
  ModelPtr bare;
  if (!scene_.cameras.empty()) {
    SceneSpec without = scene_;
    without.cameras.clear();
    bare = compile_model(scene_mjcf(without, nominal), scene_.file.string());
  }
  const mjModel* hashed = bare ? bare.get() : m_;
  std::vector<unsigned char> bytes(static_cast<std::size_t>(mj_sizeModel(hashed)));
  mj_saveModel(hashed, nullptr, bytes.data(), static_cast<int>(bytes.size()));
  model_hash_ = fnv1a64(bytes.data(), bytes.size());
  jacp_.resize(3 * m_->nv);
  jacr_.resize(3 * m_->nv);

  ids_ = std::make_unique<Ids>();
  auto need = [&](mjtObj type, const std::string& name) {
    const int id = mj_name2id(m_, type, name.c_str());
    if (id < 0) throw std::runtime_error("workcell model has no " + name);
    return id;
  };
  for (int i = 0; i < 7; ++i) {
    const auto& j = scene_.robot.arm[i];
    const int jid = need(mjOBJ_JOINT, j.name);
    ids_->arm_qpos[i] = m_->jnt_qposadr[jid];
    ids_->arm_dof[i] = m_->jnt_dofadr[jid];
    ids_->arm_act[i] = need(mjOBJ_ACTUATOR, j.name + "_motor");
    ids_->q_lower.push_back(j.lower);
    ids_->q_upper.push_back(j.upper);
    ids_->effort.push_back(j.effort);
  }
  for (const auto& f : scene_.robot.fingers)
    ids_->finger_qpos.push_back(m_->jnt_qposadr[need(mjOBJ_JOINT, f.name)]);
  ids_->gripper_act = need(mjOBJ_ACTUATOR, "gripper");
  ids_->tcp_site = need(mjOBJ_SITE, "tcp");
  ids_->finger_left_body = m_->jnt_bodyid[need(mjOBJ_JOINT, scene_.robot.fingers.front().name)];
  ids_->finger_right_body = m_->jnt_bodyid[need(mjOBJ_JOINT, scene_.robot.fingers.back().name)];
  for (std::size_t k = 0; k < scene_.entities.size(); ++k) {
    const auto& e = scene_.entities[k];
    if (e.fixture()) {
      ids_->fixture_body.push_back(need(mjOBJ_BODY, e.name));
      ids_->fixture_entity.push_back(k);
      for (const auto& part : e.asset.parts)
        ids_->parts.push_back({part_body(e.name, part.name), part.kind, need(mjOBJ_BODY, part_body(e.name, part.name)),
                               need(mjOBJ_SITE, part_grip_site(e.name, part.name)),
                               m_->jnt_qposadr[need(mjOBJ_JOINT, part_joint(e.name, part.name))], part.grip.half});
      continue;
    }
    ids_->object_body.push_back(need(mjOBJ_BODY, e.name));
    ids_->object_qpos.push_back(m_->jnt_qposadr[need(mjOBJ_JOINT, e.name + "_free")]);
    ids_->object_entity.push_back(k);
  }
  for (int s = 0; s < m_->nsite; ++s)
    if (s != ids_->tcp_site && std::none_of(ids_->parts.begin(), ids_->parts.end(),
                                            [&](const Ids::Part& p) { return p.grip_site == s; }))
      ids_->region_site.push_back(s);
}

Workcell::~Workcell() {
  if (ik_) mj_deleteData(ik_);
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

void Workcell::reset(std::uint64_t seed, const std::vector<PredicateSpec>& goal) {
  auto evaluator = std::make_unique<GoalEvaluator>(m_, scene_, goal);
  const auto placements = sample_placements(scene_, seed);
  goal_ = std::move(evaluator);
  mj_resetData(m_, d_);
  for (int i = 0; i < 7; ++i) d_->qpos[ids_->arm_qpos[i]] = scene_.ready_q[i];
  for (int a : ids_->finger_qpos) d_->qpos[a] = 0.04;
  for (std::size_t i = 0; i < ids_->object_body.size(); ++i) {
    const Placement& p = placements[ids_->object_entity[i]];
    double* q = d_->qpos + ids_->object_qpos[i];
    q[0] = p.x;
    q[1] = p.y;
    q[2] = 0.001;
    q[3] = std::cos(p.yaw / 2);
    q[4] = 0;
    q[5] = 0;
    q[6] = std::sin(p.yaw / 2);
  }
  for (const auto& e : scene_.entities)
    for (const auto& [part, q] : e.init_joints)
      d_->qpos[m_->jnt_qposadr[mj_name2id(m_, mjOBJ_JOINT, part_joint(e.name, part).c_str())]] = q;
  mj_forward(m_, d_);
  // Settle: hold the ready pose with the gripper open for 0.4 s.
  for (int s = 0; s < 8; ++s) step({0, 0, 0, 0, 0, 0, -1});
}

std::array<double, 4> Workcell::tcp_quat(const mjData_* d) const {
  std::array<double, 4> q{};
  mju_mat2Quat(q.data(), d->site_xmat + 9 * ids_->tcp_site);
  return q;
}

void Workcell::solve_ik(const std::array<double, 3>& p_goal, const std::array<double, 4>& q_goal, double joints[7]) {
  std::memcpy(ik_->qpos, d_->qpos, sizeof(mjtNum) * m_->nq);
  const Eigen::Quaterniond goal_rot = geo::quat(q_goal);
  Eigen::Matrix<double, 7, 1> q_ready;
  for (int i = 0; i < 7; ++i) q_ready[i] = scene_.ready_q[i];
  Eigen::Matrix<double, 6, 7> J;
  for (int iter = 0; iter < 4; ++iter) {
    mj_kinematics(m_, ik_);
    mj_comPos(m_, ik_);
    Eigen::Matrix<double, 6, 1> err;
    err.head<3>() = geo::vec(p_goal) - Eigen::Map<const Eigen::Vector3d>(ik_->site_xpos + 3 * ids_->tcp_site);
    err.tail<3>() = geo::rotvec_between(geo::quat(tcp_quat(ik_)), goal_rot);
    // mj_jacSite writes row-major 3 x nv.
    mj_jacSite(m_, ik_, jacp_.data(), jacr_.data(), ids_->tcp_site);
    for (int i = 0; i < 7; ++i)
      for (int k = 0; k < 3; ++k) {
        J(k, i) = jacp_[k * m_->nv + ids_->arm_dof[i]];
        J(3 + k, i) = jacr_[k * m_->nv + ids_->arm_dof[i]];
      }
    const Eigen::Matrix<double, 6, 6> JJt =
        J * J.transpose() + kIkDamping * kIkDamping * Eigen::Matrix<double, 6, 6>::Identity();
    const Eigen::Matrix<double, 7, 6> Jpinv = J.transpose() * JJt.inverse();
    Eigen::Matrix<double, 7, 1> q;
    for (int i = 0; i < 7; ++i) q[i] = ik_->qpos[ids_->arm_qpos[i]];
    const Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Identity() - Jpinv * J;
    const Eigen::Matrix<double, 7, 1> step = Jpinv * err + N * (kNullGain * (q_ready - q));
    for (int i = 0; i < 7; ++i)
      ik_->qpos[ids_->arm_qpos[i]] =
          std::clamp(q[i] + step[i], ids_->q_lower[i] + 0.01, ids_->q_upper[i] - 0.01);
  }
  for (int i = 0; i < 7; ++i) joints[i] = ik_->qpos[ids_->arm_qpos[i]];
}

std::vector<StepEvent> Workcell::step(const std::array<double, 7>& action_in) {
  std::vector<StepEvent> events;
  std::array<double, 7> a{};
  for (int i = 0; i < 7; ++i) a[i] = std::clamp(std::isfinite(action_in[i]) ? action_in[i] : 0.0, -1.0, 1.0);
  for (int i = 0; i < 7; ++i)
    if (a[i] != action_in[i]) {
      events.push_back({StepEvent::ActionClamped, "action component " + std::to_string(i) + " = " +
                                                      std::to_string(action_in[i]) +
                                                      " is not finite or outside [-1, 1]; applied as " +
                                                      std::to_string(a[i])});
      break;
    }

  const double* p = d_->site_xpos + 3 * ids_->tcp_site;
  std::array<double, 3> p_goal{p[0] + robot::kMaxDeltaPosM * a[0], p[1] + robot::kMaxDeltaPosM * a[1],
                               p[2] + robot::kMaxDeltaPosM * a[2]};
  if (clamp_to_workspace(p_goal, limits_))
    events.push_back({StepEvent::WorkspaceClamp, "position target clamped into the workspace box"});
  // Rotation target: world-frame delta (axis-angle) applied to the current orientation.
  const Eigen::Vector3d rv(robot::kMaxDeltaRotRad * a[3], robot::kMaxDeltaRotRad * a[4], robot::kMaxDeltaRotRad * a[5]);
  Eigen::Quaterniond delta = Eigen::Quaterniond::Identity();
  if (rv.norm() > 1e-12) delta = Eigen::AngleAxisd(rv.norm(), rv.normalized());
  const auto q_goal_rot = geo::wxyz(delta * geo::quat(tcp_quat(d_)));

  double q_goal[7];
  solve_ik(p_goal, q_goal_rot, q_goal);
  std::array<double, 7> q0{}, v_ref{};
  constexpr double period = kSubsteps * 0.002;
  for (int i = 0; i < 7; ++i) {
    q0[i] = d_->qpos[ids_->arm_qpos[i]];
    const double vmax = kRefSpeedFraction * limits_.joint_speed;
    v_ref[i] = std::clamp((q_goal[i] - q0[i]) / period, -vmax, vmax);
  }
  d_->ctrl[ids_->gripper_act] = robot::finger_target(a[6]);

  bool hold = false;
  std::array<double, 7> q_hold{};
  for (int s = 1; s <= kSubsteps; ++s) {
    mj_step1(m_, d_);
    const double t = s * 0.002;
    for (int i = 0; i < 7; ++i) {
      double q_ref = q0[i] + v_ref[i] * t, dq_ref = v_ref[i];
      if ((v_ref[i] > 0 && q_ref > q_goal[i]) || (v_ref[i] < 0 && q_ref < q_goal[i])) {
        q_ref = q_goal[i];
        dq_ref = 0;
      }
      if (hold) q_ref = q_hold[i], dq_ref = 0;
      const double q = d_->qpos[ids_->arm_qpos[i]], dq = d_->qvel[ids_->arm_dof[i]];
      const double tau = kKp[i] * (q_ref - q) + kKd[i] * (dq_ref - dq) + d_->qfrc_bias[ids_->arm_dof[i]];
      d_->ctrl[ids_->arm_act[i]] = std::clamp(tau, -ids_->effort[i], ids_->effort[i]);
    }
    mj_step2(m_, d_);
    if (s % kSafetyEvery == 0 && !hold) {
      std::array<double, 7> dq{};
      for (int i = 0; i < 7; ++i) dq[i] = d_->qvel[ids_->arm_dof[i]];
      const SafetyVerdict v = check_joint_speeds(dq, limits_);
      if (!v.ok) {
        hold = true;
        for (int i = 0; i < 7; ++i) q_hold[i] = d_->qpos[ids_->arm_qpos[i]];
        events.push_back({StepEvent::SafetyHold, v.reason + "; holding position"});
      }
    }
  }
  capture(ended_);
  mj_forward(m_, d_);
  // MuJoCo drops contacts and constraints silently when its buffers are full; that physics is wrong.
  for (int w : {mjWARN_CONTACTFULL, mjWARN_CNSTRFULL})
    if (d_->warning[w].number > 0)
      throw std::runtime_error(scene_.name + ": MuJoCo's " + (w == mjWARN_CONTACTFULL ? "contact" : "constraint") +
                               " buffer overflowed (raise nconmax/njmax in scene_mjcf)");
  return events;
}

bool Workcell::in_contact(int body_a, int body_b) const {
  for (int i = 0; i < d_->ncon; ++i) {
    const int b1 = m_->geom_bodyid[d_->contact[i].geom1], b2 = m_->geom_bodyid[d_->contact[i].geom2];
    if ((b1 == body_a && b2 == body_b) || (b1 == body_b && b2 == body_a)) return true;
  }
  return false;
}

bool Workcell::goal_holds() const { return goal_ && goal_->holds(d_); }

bool Workcell::holds(const std::vector<PredicateSpec>& goal) const { return GoalEvaluator(m_, scene_, goal).holds(d_); }

double Workcell::max_penetration() const {
  double deepest = 0;
  for (int i = 0; i < d_->ncon; ++i) {
    const int b1 = m_->body_rootid[m_->geom_bodyid[d_->contact[i].geom1]];
    const int b2 = m_->body_rootid[m_->geom_bodyid[d_->contact[i].geom2]];
    auto scene_entity = [&](int root) {
      return std::find(ids_->object_body.begin(), ids_->object_body.end(), root) != ids_->object_body.end() ||
             std::find(ids_->fixture_body.begin(), ids_->fixture_body.end(), root) != ids_->fixture_body.end();
    };
    if (scene_entity(b1) || scene_entity(b2)) deepest = std::max(deepest, -d_->contact[i].dist);
  }
  return deepest;
}

double Workcell::max_object_speed() const {
  double fastest = 0;
  for (int b : ids_->object_body) {
    double v[6];
    mj_objectVelocity(m_, d_, mjOBJ_BODY, b, v, 0);
    fastest = std::max(fastest, std::hypot(v[3], v[4], v[5]));
  }
  return fastest;
}

Observation Workcell::observe() const {
  Observation o;
  const double* p = d_->site_xpos + 3 * ids_->tcp_site;
  std::copy(p, p + 3, o.ee_p.begin());
  o.ee_q = tcp_quat(d_);
  for (int a : ids_->finger_qpos) o.gripper_opening += d_->qpos[a];
  for (int i = 0; i < 7; ++i) {
    o.q[i] = d_->qpos[ids_->arm_qpos[i]];
    o.dq[i] = d_->qvel[ids_->arm_dof[i]];
  }
  auto entity = [&](int body, const EntitySpec& spec) {
    EntityState e;
    e.name = spec.name;
    e.kind = spec.asset.kind;
    std::copy(d_->xpos + 3 * body, d_->xpos + 3 * body + 3, e.p.begin());
    std::copy(d_->xquat + 4 * body, d_->xquat + 4 * body + 4, e.q.begin());
    e.half_extents = spec.asset.half_extents();
    return e;
  };
  for (std::size_t k = 0; k < ids_->object_body.size(); ++k) {
    const int b = ids_->object_body[k];
    o.contact_left |= in_contact(ids_->finger_left_body, b);
    o.contact_right |= in_contact(ids_->finger_right_body, b);
    o.entities.push_back(entity(b, scene_.entities[ids_->object_entity[k]]));
  }
  for (std::size_t k = 0; k < ids_->fixture_body.size(); ++k)
    o.entities.push_back(entity(ids_->fixture_body[k], scene_.entities[ids_->fixture_entity[k]]));
  for (const auto& part : ids_->parts) {
    EntityState e;
    e.name = part.name;
    e.kind = part.kind;
    std::copy(d_->site_xpos + 3 * part.grip_site, d_->site_xpos + 3 * part.grip_site + 3, e.p.begin());
    std::copy(d_->xquat + 4 * part.body, d_->xquat + 4 * part.body + 4, e.q.begin());
    e.half_extents = part.grip_half;
    e.joint = d_->qpos[part.qpos];
    o.entities.push_back(std::move(e));
  }
  for (int s : ids_->region_site) {
    EntityState e;
    e.name = mj_id2name(m_, mjOBJ_SITE, s);
    e.kind = "region";
    std::copy(d_->site_xpos + 3 * s, d_->site_xpos + 3 * s + 3, e.p.begin());
    mju_mat2Quat(e.q.data(), d_->site_xmat + 9 * s);
    std::copy(m_->site_size + 3 * s, m_->site_size + 3 * s + 3, e.half_extents.begin());
    o.entities.push_back(std::move(e));
  }
  o.goal_holds = goal_holds();
  return o;
}

StateDigest Workcell::digest() const {
  const auto bytes = [](int n) { return static_cast<std::size_t>(n) * sizeof(mjtNum); };
  StateDigest g;
  std::uint64_t h = fnv1a64(&d_->time, sizeof d_->time);
  h = fnv1a64(d_->qpos, bytes(m_->nq), h);
  h = fnv1a64(d_->qvel, bytes(m_->nv), h);
  h = fnv1a64(d_->act, bytes(m_->na), h);
  h = fnv1a64(d_->ctrl, bytes(m_->nu), h);
  g.state = fnv1a64(d_->qacc_warmstart, bytes(m_->nv), h);
  g.aux = {fnv1a32(&d_->time, sizeof d_->time), fnv1a32(d_->act, bytes(m_->na)),
           fnv1a32(d_->ctrl, bytes(m_->nu)), fnv1a32(d_->qacc_warmstart, bytes(m_->nv))};
  g.joints.reserve(2 * m_->njnt);
  for (int j = 0; j < m_->njnt; ++j) {
    const int type = m_->jnt_type[j];
    const int nq = type == mjJNT_FREE ? 7 : type == mjJNT_BALL ? 4 : 1;
    const int nv = type == mjJNT_FREE ? 6 : type == mjJNT_BALL ? 3 : 1;
    g.joints.push_back(fnv1a32(d_->qpos + m_->jnt_qposadr[j], bytes(nq)));
    g.joints.push_back(fnv1a32(d_->qvel + m_->jnt_dofadr[j], bytes(nv)));
  }
  return g;
}

StateShape Workcell::shape() const {
  const auto u = [](int n) { return static_cast<std::uint32_t>(n); };
  return {u(m_->nq), u(m_->nv), u(m_->na), u(m_->nu), u(m_->nmocap), u(m_->nbody)};
}

void Workcell::capture(PhysicsState& s) const {
  // assign() reuses the vectors' storage: this runs at every control step.
  const auto copy = [](std::vector<double>& v, const mjtNum* p, int n) { v.assign(p, p + n); };
  s.time = d_->time;
  copy(s.qpos, d_->qpos, m_->nq);
  copy(s.qvel, d_->qvel, m_->nv);
  copy(s.act, d_->act, m_->na);
  copy(s.ctrl, d_->ctrl, m_->nu);
  copy(s.qacc_warmstart, d_->qacc_warmstart, m_->nv);
  copy(s.mocap_pos, d_->mocap_pos, 3 * m_->nmocap);
  copy(s.mocap_quat, d_->mocap_quat, 4 * m_->nmocap);
  copy(s.qfrc_applied, d_->qfrc_applied, m_->nv);
  copy(s.xfrc_applied, d_->xfrc_applied, 6 * m_->nbody);
}

void Workcell::restore(const PhysicsState& s) {
  const StateShape here = shape();
  if (!here.fits(s))
    throw std::invalid_argument(scene_.name + ": a recorded state does not fit this model (" + here.str() +
                                "); it was recorded with another scene or robot");
  const auto put = [](const std::vector<double>& v, mjtNum* p) { std::copy(v.begin(), v.end(), p); };
  d_->time = s.time;
  put(s.qpos, d_->qpos);
  put(s.qvel, d_->qvel);
  put(s.act, d_->act);
  put(s.ctrl, d_->ctrl);
  put(s.qacc_warmstart, d_->qacc_warmstart);
  put(s.mocap_pos, d_->mocap_pos);
  put(s.mocap_quat, d_->mocap_quat);
  put(s.qfrc_applied, d_->qfrc_applied);
  put(s.xfrc_applied, d_->xfrc_applied);
  mj_forward(m_, d_);
  ended_ = s;
}

}  // namespace dh::sim
