#include "dh/sim/workcell.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "dh/common/digest.hpp"
#include "dh/common/geometry.hpp"
#include "dh/common/robot_contract.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/placing.hpp"

namespace dh::sim {

namespace {
// The controller's speed limiter sits below the seam's envelope, so the envelope only trips on faults.
constexpr double kLimiterFraction = 0.9;
}  // namespace

struct Workcell::Ids {
  std::size_t arm = 0;  ///< arm joints: 6 or 7; the arrays' first `arm` entries are used
  std::array<int, 7> arm_qpos{}, arm_dof{}, arm_act{};
  std::vector<int> finger_qpos;
  int gripper_act = -1;
  int tcp_site = -1;
  int finger_left_body = -1, finger_right_body = -1;
  std::vector<int> object_body;            ///< free objects, in scene order
  std::vector<std::size_t> object_entity;  ///< index into scene.entities
  std::vector<int> fixture_body;
  std::vector<std::size_t> fixture_entity;
  struct Part {
    std::string name, kind, owner;
    int body = -1, grip_site = -1, qpos = -1;
    std::array<double, 3> grip_half{};
  };
  std::vector<Part> parts;  ///< fixtures' articulated parts, in scene order
  struct Region {
    int site = -1;
    std::string owner, relation;
  };
  std::vector<Region> regions;  ///< every other site: table regions and asset regions
  std::array<double, 7> effort{};
};

Workcell::Workcell(SceneSpec scene) : scene_(std::move(scene)) {
  limits_.workspace_min = scene_.workspace_min;
  limits_.workspace_max = scene_.workspace_max;
  // The envelope: the paper's 2 rad/s, never above any joint's own URDF limit.
  for (const auto& j : scene_.robot.arm) limits_.joint_speed = std::min(limits_.joint_speed, j.velocity);

  const std::vector<Placement> nominal = nominal_placements(scene_);
  // The bodies that can never touch are read off the model without exclusions (compiled the first time
  // this process builds the scene, and then the workcell's own when there are none) and left out of the
  // workcell's collision detection.
  const std::string all_pairs = scene_mjcf(scene_, nominal);
  ModelPtr model;
  const std::vector<BodyPair> exclude = never_touching(all_pairs, scene_.file.string(), &model);
  if (!exclude.empty())
    model = compile_model(scene_mjcf(scene_, nominal, exclude), scene_.file.string());
  else if (!model)
    model = compile_model(all_pairs, scene_.file.string());
  m_ = model.release();
  d_ = mj_makeData(m_);
  // The hash is of the model without the RGB-D cameras a simulator worker adds (configs/cameras.yaml):
  // they render, they do not move anything, and an in-process run has none.
  ModelPtr bare;
  if (!scene_.cameras.empty()) {
    SceneSpec without = scene_;
    without.cameras.clear();
    bare = compile_model(scene_mjcf(without, nominal, exclude), scene_.file.string());
  }
  const mjModel* hashed = bare ? bare.get() : m_;
  std::vector<unsigned char> bytes(static_cast<std::size_t>(mj_sizeModel(hashed)));
  mj_saveModel(hashed, nullptr, bytes.data(), static_cast<int>(bytes.size()));
  model_hash_ = fnv1a64(bytes.data(), bytes.size());

  ids_ = std::make_unique<Ids>();
  auto need = [&](mjtObj type, const std::string& name) {
    const int id = mj_name2id(m_, type, name.c_str());
    if (id < 0) throw std::runtime_error("workcell model has no " + name);
    return id;
  };
  ids_->arm = scene_.robot.arm.size();
  for (std::size_t i = 0; i < ids_->arm; ++i) {
    const auto& j = scene_.robot.arm[i];
    const int jid = need(mjOBJ_JOINT, j.name);
    ids_->arm_qpos[i] = m_->jnt_qposadr[jid];
    ids_->arm_dof[i] = m_->jnt_dofadr[jid];
    ids_->arm_act[i] = need(mjOBJ_ACTUATOR, j.name + "_motor");
    ids_->effort[i] = j.effort;
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
        ids_->parts.push_back(
            {part_body(e.name, part.name), part.kind, e.name, need(mjOBJ_BODY, part_body(e.name, part.name)),
             need(mjOBJ_SITE, part_grip_site(e.name, part.name)),
             m_->jnt_qposadr[need(mjOBJ_JOINT, part_joint(e.name, part.name))], part.grip.half});
      continue;
    }
    ids_->object_body.push_back(need(mjOBJ_BODY, e.name));
    ids_->object_entity.push_back(k);
  }
  OscGains gains;
  gains.speed_limit = kLimiterFraction * limits_.joint_speed;
  std::array<double, 7> ready{};
  std::copy(scene_.ready_q.begin(), scene_.ready_q.end(), ready.begin());
  if (scene_.controller == "osc_pose") {
    osc_ = std::make_unique<OscPose>(m_, ids_->arm, ids_->arm_dof, ids_->arm_qpos, ids_->tcp_site, ready,
                                     ids_->effort, gains);
  } else {
    std::array<double, 7> lower{}, upper{};
    for (int i = 0; i < 7; ++i) lower[i] = scene_.robot.arm[i].lower, upper[i] = scene_.robot.arm[i].upper;
    ik_ = std::make_unique<JointIk>(m_, ids_->arm_dof, ids_->arm_qpos, ids_->tcp_site, ready, lower, upper,
                                    ids_->effort, gains.speed_limit);
  }
  for (const auto& r : scene_.regions) ids_->regions.push_back({need(mjOBJ_SITE, r.name), r.of, r.relation});
  for (const auto& e : scene_.entities) {
    for (const auto& s : e.asset.sites)
      ids_->regions.push_back({need(mjOBJ_SITE, e.name + "_" + s.name), e.name, s.relation});
    for (const auto& part : e.asset.parts)
      for (const auto& s : part.sites)
        ids_->regions.push_back(
            {need(mjOBJ_SITE, e.name + "_" + s.name), part_body(e.name, part.name), s.relation});
  }
  std::sort(ids_->regions.begin(), ids_->regions.end(),
            [](const Ids::Region& a, const Ids::Region& b) { return a.site < b.site; });
}

Workcell::~Workcell() {
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

void Workcell::reset(std::uint64_t seed, const std::vector<PredicateSpec>& goal) {
  auto evaluator = std::make_unique<GoalEvaluator>(m_, scene_, goal);
  const auto placements = sample_placements(scene_, seed);
  goal_ = std::move(evaluator);
  mj_resetData(m_, d_);
  for (std::size_t i = 0; i < ids_->arm; ++i) d_->qpos[ids_->arm_qpos[i]] = scene_.ready_q[i];
  for (int a : ids_->finger_qpos) d_->qpos[a] = 0.04;
  place_entities(m_, d_, scene_, placements);
  mj_forward(m_, d_);
  // The controller starts with the orientation it finds, as robosuite's does when it is made at reset.
  if (osc_) {
    osc_->set_orientation_goal(geo::quat(tcp_quat(d_)));
    store_controller();
  }
  // Settle: hold the ready pose with the gripper open for 0.4 s.
  for (int s = 0; s < 8; ++s) step({0, 0, 0, 0, 0, 0, -1});
}

std::array<double, 4> Workcell::tcp_quat(const mjData_* d) const {
  std::array<double, 4> q{};
  mju_mat2Quat(q.data(), d->site_xmat + 9 * ids_->tcp_site);
  return q;
}

void Workcell::store_controller() {
  const auto q = osc_->orientation_goal();
  d_->userdata[0] = q.w();
  d_->userdata[1] = q.x();
  d_->userdata[2] = q.y();
  d_->userdata[3] = q.z();
  // The controller goes on from the goal as stored, which is what restore() rebuilds: a rotation matrix does
  // not survive its quaternion bit for bit, and a restored state would step on from a goal 1e-16 apart.
  osc_->set_orientation_goal(
      Eigen::Quaterniond(d_->userdata[0], d_->userdata[1], d_->userdata[2], d_->userdata[3]));
}

std::vector<StepEvent> Workcell::step(const std::array<double, 7>& action_in) {
  std::vector<StepEvent> events;
  std::array<double, 7> a = action_in;
  if (auto why = clamp_action(a)) events.push_back({StepEvent::ActionClamped, std::move(*why)});

  const double* p = d_->site_xpos + 3 * ids_->tcp_site;
  std::array<double, 3> p_goal{p[0] + robot::kMaxDeltaPosM * a[0], p[1] + robot::kMaxDeltaPosM * a[1],
                               p[2] + robot::kMaxDeltaPosM * a[2]};
  if (clamp_to_workspace(p_goal, limits_))
    events.push_back({StepEvent::WorkspaceClamp, "position target clamped into the workspace box"});
  const Eigen::Vector3d dr(robot::kMaxDeltaRotRad * a[3], robot::kMaxDeltaRotRad * a[4],
                           robot::kMaxDeltaRotRad * a[5]);
  constexpr double period = kSubsteps * 0.002;
  if (osc_) {
    osc_->set_goal(d_, geo::vec(p_goal) - Eigen::Map<const Eigen::Vector3d>(p), dr);
    store_controller();
  } else {
    Eigen::Quaterniond delta = Eigen::Quaterniond::Identity();
    if (dr.norm() > 1e-12) delta = Eigen::AngleAxisd(dr.norm(), dr.normalized());
    ik_->set_goal(d_, geo::vec(p_goal), delta * geo::quat(tcp_quat(d_)), period);
  }
  d_->ctrl[ids_->gripper_act] = robot::finger_target(a[6]);

  bool hold = false;
  int limited = 0;
  std::array<double, 7> q_hold{}, tau{};
  for (int s = 1; s <= kSubsteps; ++s) {
    mj_step1(m_, d_);
    if (hold) {
      joint_pd(d_, ids_->arm_dof, ids_->arm_qpos, q_hold, {}, ids_->effort, tau, ids_->arm);
    } else if (osc_) {
      limited += osc_->torques(d_, tau);
    } else {
      ik_->torques(d_, s * 0.002, tau);
    }
    for (std::size_t i = 0; i < ids_->arm; ++i) d_->ctrl[ids_->arm_act[i]] = tau[i];
    mj_step2(m_, d_);
    if (s % kSafetyEvery == 0 && !hold) {
      std::array<double, 7> dq{};
      for (std::size_t i = 0; i < ids_->arm; ++i) dq[i] = d_->qvel[ids_->arm_dof[i]];
      const SafetyVerdict v = check_joint_speeds(dq, limits_);
      if (!v.ok) {
        hold = true;
        for (std::size_t i = 0; i < ids_->arm; ++i) q_hold[i] = d_->qpos[ids_->arm_qpos[i]];
        events.push_back({StepEvent::SafetyHold, v.reason + "; holding position"});
      }
    }
  }
  if (limited > 0)
    events.push_back({StepEvent::SpeedLimited, "the controller braked an arm joint above " +
                                                   std::to_string(kLimiterFraction * limits_.joint_speed) +
                                                   " rad/s in " + std::to_string(limited) + " of " +
                                                   std::to_string(kSubsteps) + " substeps"});
  capture(ended_);
  mj_forward(m_, d_);
  // MuJoCo drops contacts and constraints silently when its buffers are full; that physics is wrong.
  for (int w : {mjWARN_CONTACTFULL, mjWARN_CNSTRFULL})
    if (d_->warning[w].number > 0)
      throw std::runtime_error(scene_.name + ": MuJoCo's " +
                               (w == mjWARN_CONTACTFULL ? "contact" : "constraint") +
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

bool Workcell::holds(const std::vector<PredicateSpec>& goal) const {
  return GoalEvaluator(m_, scene_, goal).holds(d_);
}

double Workcell::max_penetration() const {
  double deepest = 0;
  for (int i = 0; i < d_->ncon; ++i) {
    const int b1 = m_->body_rootid[m_->geom_bodyid[d_->contact[i].geom1]];
    const int b2 = m_->body_rootid[m_->geom_bodyid[d_->contact[i].geom2]];
    auto scene_entity = [&](int root) {
      return std::find(ids_->object_body.begin(), ids_->object_body.end(), root) != ids_->object_body.end() ||
             std::find(ids_->fixture_body.begin(), ids_->fixture_body.end(), root) !=
                 ids_->fixture_body.end();
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
  o.gripper = scene_.gripper;
  o.base_p = scene_.robot_base;
  for (int a : ids_->finger_qpos) o.gripper_opening += d_->qpos[a];
  for (std::size_t i = 0; i < ids_->arm; ++i) {  // a 6-joint arm leaves the seventh 0
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
    e.category = spec.asset.category;
    e.colour = spec.colour;
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
    e.category = part.kind;
    e.owner = part.owner;
    o.entities.push_back(std::move(e));
  }
  for (const auto& [s, owner, relation] : ids_->regions) {
    EntityState e;
    e.owner = owner;
    e.relation = relation;
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

std::uint32_t Workcell::engine_version() const { return static_cast<std::uint32_t>(mj_version()); }

StateShape Workcell::shape() const {
  const auto u = [](int n) { return static_cast<std::uint32_t>(n); };
  return {u(m_->nq), u(m_->nv), u(m_->na), u(m_->nu), u(m_->nmocap), u(m_->nbody), u(m_->nuserdata)};
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
  copy(s.userdata, d_->userdata, m_->nuserdata);
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
  put(s.userdata, d_->userdata);
  if (osc_)
    osc_->set_orientation_goal(
        Eigen::Quaterniond(s.userdata[0], s.userdata[1], s.userdata[2], s.userdata[3]));
  mj_forward(m_, d_);
  ended_ = s;
}

}  // namespace dh::sim
