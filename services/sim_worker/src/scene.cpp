#include "dh/sim/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/sim/config_arrays.hpp"
#include "dh/sim/object_variation.hpp"
#include "mjcf_text.hpp"
#include "uniform_draw.hpp"

namespace dh::sim {

namespace {

using mjcf::num;
constexpr auto vec = mjcf::list;

std::string yaw_quat(double yaw) { return num(std::cos(yaw / 2)) + " 0 0 " + num(std::sin(yaw / 2)); }

EntitySpec load_entity(const ConfigNode& n, const std::filesystem::path& assets_dir) {
  EntitySpec e;
  e.name = n.get<std::string>("name");
  const auto asset = n.get<std::string>("asset");
  const auto file = assets_dir / (asset + ".yaml");
  if (!std::filesystem::exists(file)) n.fail("asset", "no asset '" + asset + "' (" + file.string() + " does not exist)");
  e.asset = load_asset(file);
  e.rgba = n.has("rgba") ? get_array<4>(n, "rgba") : e.asset.rgba;
  if (n.has("rgba") && !n.has("colour")) n.fail("colour", "a repainted entity says its colour in words too");
  e.colour = n.get_or<std::string>("colour", e.asset.colour);
  e.nominal_xy = get_array<2>(n, "xy");
  e.yaw = n.get_or<double>("yaw", 0.0);
  e.jitter = n.get_or<double>("jitter", 0.0);
  e.yaw_jitter = n.get_or<double>("yaw_jitter", 0.0);
  if (e.fixture() && (e.jitter != 0 || e.yaw_jitter != 0))
    n.fail("jitter", "fixtures stand where the scene puts them; remove jitter from '" + e.name + "'");
  if (n.has("init")) {
    const ConfigNode init = n.child("init");
    for (const auto& part : init.keys()) {
      const bool known = std::any_of(e.asset.parts.begin(), e.asset.parts.end(),
                                     [&](const PartSpec& p) { return p.name == part; });
      if (!known) init.fail(part, "asset '" + asset + "' has no articulated part '" + part + "'");
      e.init_joints[part] = init.get<double>(part);
    }
  }
  return e;
}

std::string geom_xml(const GeomSpec& g, const std::string& name, const std::array<double, 4>& colour,
                     double friction, double density, int condim) {
  const auto& c = g.rgba ? *g.rgba : colour;
  const std::string common = " friction=\"" + num(friction) + " 0.02 0.001\" condim=\"" + std::to_string(condim) +
                             "\" density=\"" + num(density) + "\" rgba=\"" + vec(c.data(), 4) + "\"/>\n";
  switch (g.type) {
    case GeomSpec::Type::Box:
      return "<geom name=\"" + name + "\" type=\"box\" size=\"" + vec(g.size.data(), 3) + "\" pos=\"" +
             vec(g.pos.data(), 3) + "\" quat=\"" + yaw_quat(g.yaw) + "\"" + common;
    case GeomSpec::Type::Cylinder:
      return "<geom name=\"" + name + "\" type=\"cylinder\" size=\"" + vec(g.size.data(), 2) + "\" pos=\"" +
             vec(g.pos.data(), 3) + "\"" + common;
    case GeomSpec::Type::Disc: {
      // Boxes whose corners lie on the rim, turned by pi/segments each: a regular 2·segments-gon.
      const double half_angle = std::numbers::pi / (2 * g.segments);
      const double half[3] = {g.size[0] * std::cos(half_angle), g.size[0] * std::sin(half_angle), g.size[1]};
      std::string x;
      for (int i = 0; i < g.segments; ++i)
        x += "<geom name=\"" + name + "_" + std::to_string(i) + "\" type=\"box\" size=\"" + vec(half, 3) +
             "\" pos=\"" + vec(g.pos.data(), 3) + "\" quat=\"" + yaw_quat(g.yaw + std::numbers::pi * i / g.segments) +
             "\"" + common;
      return x;
    }
    case GeomSpec::Type::Ring: {
      // A ring of wall boxes: a hollow shape (bowl, mug, pot wall) whose rim a parallel jaw can pinch.
      const double r = g.size[0] - g.size[1] / 2;
      const double chord = 2 * g.size[0] * std::sin(std::numbers::pi / g.segments) + g.size[1] / 2;
      std::string x;
      for (int i = 0; i < g.segments; ++i) {
        const double a = g.yaw + 2 * std::numbers::pi * i / g.segments;
        const double p[3] = {g.pos[0] + r * std::cos(a), g.pos[1] + r * std::sin(a), g.pos[2]};
        const double half[3] = {g.size[1] / 2, chord / 2, g.size[2]};
        x += "<geom name=\"" + name + "_" + std::to_string(i) + "\" type=\"box\" size=\"" + vec(half, 3) +
             "\" pos=\"" + vec(p, 3) + "\" quat=\"" + yaw_quat(a) + "\"" + common;
      }
      return x;
    }
  }
  return "";
}

double total_volume(const std::vector<GeomSpec>& geoms) {
  double v = 0;
  for (const auto& g : geoms) v += g.volume();
  return v;
}

std::string sites_xml(const std::vector<SiteSpec>& sites, const std::string& entity) {
  std::string x;
  for (const auto& s : sites)
    x += "<site name=\"" + entity + "_" + s.name + "\" type=\"box\" size=\"" + vec(s.half.data(), 3) + "\" pos=\"" +
         vec(s.pos.data(), 3) + "\" rgba=\"0.2 0.8 0.2 0\" group=\"3\"/>\n";
  return x;
}

std::string entity_xml(const EntitySpec& e, const Placement& p) {
  const AssetSpec& a = e.asset;
  const double lift = e.fixture() ? 0.0 : 0.001;  // free objects settle onto the table from 1 mm
  std::string x = "<body name=\"" + e.name + "\" pos=\"" + num(p.x) + " " + num(p.y) + " " + num(lift) +
                  "\" quat=\"" + yaw_quat(p.yaw) + "\">\n";
  if (!e.fixture()) x += "<freejoint name=\"" + e.name + "_free\"/>\n";
  // Free objects: the asset's mass spread over its geoms by volume, inertia from the geoms.
  const double density = e.fixture() ? 1000.0 : a.mass / total_volume(a.geoms);
  const int condim = e.fixture() ? 3 : 4;
  for (std::size_t i = 0; i < a.geoms.size(); ++i)
    x += geom_xml(a.geoms[i], e.name + "_g" + std::to_string(i), e.rgba, a.friction, density, condim);
  x += sites_xml(a.sites, e.name);
  for (const auto& part : a.parts) {
    const auto& j = part.joint;
    x += "<body name=\"" + part_body(e.name, part.name) + "\" pos=\"" + vec(part.pos.data(), 3) + "\">\n";
    x += "<joint name=\"" + part_joint(e.name, part.name) + "\" type=\"" +
         (j.type == JointSpec::Type::Slide ? "slide" : "hinge") + "\" axis=\"" + vec(j.axis.data(), 3) +
         "\" limited=\"true\" range=\"" + vec(j.range.data(), 2) + "\" damping=\"" + num(j.damping) +
         "\" frictionloss=\"" + num(j.frictionloss) + "\" stiffness=\"" + num(j.stiffness) + "\"/>\n";
    const double part_density = part.mass / total_volume(part.geoms);
    for (std::size_t i = 0; i < part.geoms.size(); ++i)
      x += geom_xml(part.geoms[i], part_body(e.name, part.name) + "_g" + std::to_string(i), e.rgba, a.friction,
                    part_density, 4);
    x += sites_xml(part.sites, e.name);
    x += "<site name=\"" + part_grip_site(e.name, part.name) + "\" type=\"box\" size=\"" +
         vec(part.grip.half.data(), 3) + "\" pos=\"" + vec(part.grip.pos.data(), 3) + "\" rgba=\"0 0 1 0\" group=\"3\"/>\n";
    x += "</body>\n";
  }
  x += "</body>\n";
  return x;
}

/// LIBERO's `agentview`: fixed in front of the table (+x, facing the robot), high enough to see over
/// the fixtures, aimed between the robot's base and the table centre. No body: no effect on physics.
std::string agentview_camera_xml(const SceneSpec& scene) {
  const double pos[3] = {scene.table_size[0] / 2 + 0.3, 0, 0.85};
  const double target[3] = {0.4 * scene.robot_base[0], 0, 0};
  return "<camera name=\"agentview\" pos=\"" + vec(pos, 3) + "\" xyaxes=\"" + mjcf::look_at(pos, target) +
         "\" fovy=\"50\"/>\n";
}

}  // namespace

std::string part_body(const std::string& entity, const std::string& part) { return entity + "_" + part; }
std::string part_joint(const std::string& entity, const std::string& part) { return entity + "_" + part + "_joint"; }
std::string part_grip_site(const std::string& entity, const std::string& part) { return entity + "_" + part + "_grip"; }

const EntitySpec* SceneSpec::entity(const std::string& n) const {
  for (const auto& e : entities)
    if (e.name == n) return &e;
  return nullptr;
}

std::filesystem::path robot_profile(const std::string& name) {
  const auto dir = paths::config_dir() / "robots";
  const auto file = dir / (name + ".yaml");
  if (name.empty() || name.find('/') != std::string::npos || !std::filesystem::exists(file)) {
    std::string known;
    for (const auto& f : std::filesystem::directory_iterator(dir))
      if (f.path().extension() == ".yaml") known += (known.empty() ? "" : ", ") + f.path().stem().string();
    throw ConfigError("no robot '" + name + "' (" + file.string() + " does not exist; robots: " + known + ")");
  }
  return file;
}

namespace {
// The arm of a scene from its profile file: URDF, ready pose, pad friction.
void load_robot_profile(SceneSpec& s, const std::filesystem::path& file) {
  const ConfigNode p = ConfigNode::load_file(file);
  s.robot = load_robot(file.parent_path() / p.get<std::string>("urdf"));
  s.robot_profile = file.stem().string();
  s.ready_q = p.get<std::vector<double>>("ready_q");
  if (s.ready_q.size() != s.robot.arm.size())
    p.fail("ready_q", std::to_string(s.ready_q.size()) + " values for the " + std::to_string(s.robot.arm.size()) +
                          " arm joints of " + s.robot.urdf.string());
  s.finger_friction = p.get_or<double>("finger_friction", 1.5);
  const ConfigNode g = p.child("gripper");
  s.gripper = {g.get<double>("pad_below_tcp"), g.get<double>("pad_half_width"), g.get<double>("pad_thickness"),
               g.get<double>("hand_above_tcp")};
}
}  // namespace

SceneSpec load_scene(const std::filesystem::path& file, const std::filesystem::path& robot) {
  const ConfigNode root = ConfigNode::load_file(file);
  SceneSpec s;
  s.file = file;
  s.name = root.get<std::string>("scene");
  s.layout = root.get_or<std::string>("layout", "kitchen");
  const ConfigNode table = root.child("table");
  s.table_size = get_array<3>(table, "size");
  s.table_friction = table.get_or<double>("friction", 1.0);
  if (table.has("rgba")) s.table_rgba = get_array<4>(table, "rgba");
  const ConfigNode mount = root.child("robot");
  load_robot_profile(s, robot.empty() ? root.dir() / mount.get<std::string>("profile") : robot);
  s.robot_base = get_array<3>(mount, "base");
  s.controller = mount.get_or<std::string>("controller", "osc_pose");
  if (s.controller != "joint_ik" && s.controller != "osc_pose")
    mount.fail("controller", "expected joint_ik or osc_pose, not '" + s.controller + "'");
  if (s.controller == "joint_ik" && s.robot.arm.size() != 7)
    mount.fail("controller", "joint_ik drives 7-joint arms; " + s.robot.urdf.string() + " has " +
                                 std::to_string(s.robot.arm.size()) + " (use osc_pose)");
  const ConfigNode ws = root.child("workspace");
  s.workspace_min = get_array<3>(ws, "min");
  s.workspace_max = get_array<3>(ws, "max");
  const auto assets_dir = root.dir() / ".." / "assets";
  for (const ConfigNode& n : root.items("entities")) {
    EntitySpec e = load_entity(n, assets_dir);
    if (s.entity(e.name)) n.fail("name", "entity '" + e.name + "' is defined twice");
    s.entities.push_back(std::move(e));
  }
  if (root.has("regions"))
    for (const ConfigNode& n : root.items("regions")) {
      TableRegion r{n.get<std::string>("name"), n.get<std::string>("relation"), n.get<std::string>("of"),
                    get_array<2>(n, "xy"), get_array<2>(n, "half")};
      static const std::set<std::string> kRelations{"front_of", "back_of", "left_of", "right_of"};
      if (!kRelations.count(r.relation)) n.fail("relation", "expected front_of, back_of, left_of or right_of");
      if (!s.entity(r.of)) n.fail("of", "no entity '" + r.of + "' in this scene");
      s.regions.push_back(std::move(r));
    }
  return s;
}

SceneSpec apply_swap(SceneSpec scene, const SwapSpec& swap) {
  auto find = [&](const std::string& n) {
    for (auto& e : scene.entities)
      if (e.name == n) return &e;
    throw std::invalid_argument("swap names '" + n + "', which is not an entity of scene " + scene.name);
  };
  for (const auto& [a, b] : swap.exchange) std::swap(find(a)->nominal_xy, find(b)->nominal_xy);
  for (const auto& [e, xy] : swap.moves) find(e)->nominal_xy = xy;
  return scene;
}

SceneSpec load_nominal_scene(const TaskDef& task, const std::string& robot) {
  SceneSpec scene = apply_swap(load_scene(task.scene_file, robot.empty() ? std::filesystem::path() : robot_profile(robot)),
                               task.swap);
  scene.pos = task.pos;
  return scene;
}

SceneSpec load_task_scene(const TaskDef& task, std::uint64_t seed, const std::string& robot) {
  SceneSpec scene = load_nominal_scene(task, robot);
  return task.object.empty() ? scene : vary_objects(std::move(scene), task.object, seed);
}

std::string task_scene_key(const TaskDef& task, std::uint64_t seed, const std::string& robot) {
  return task.scene_file.string() + "|" + task.swap.text() + (task.pos.empty() ? "" : "|" + task.pos.text()) +
         (task.object.empty() ? "" : "|" + task.object.text() + " seed " + std::to_string(seed)) +
         (robot.empty() ? "" : "|robot " + robot);
}

std::vector<Placement> nominal_placements(const SceneSpec& scene) {
  std::vector<Placement> nominal;
  for (const auto& e : scene.entities) nominal.push_back({e.name, e.nominal_xy[0], e.nominal_xy[1], e.yaw});
  return nominal;
}

std::vector<Placement> sample_placements(const SceneSpec& scene, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 1);
  constexpr double kClearance = 0.015;
  const std::size_t n = scene.entities.size();
  std::vector<Placement> out(n);
  std::vector<std::array<double, 2>> half(n);
  std::vector<bool> placed(n, false);
  auto overlaps = [&](std::size_t i) {
    for (std::size_t k = 0; k < n; ++k)
      if (k != i && placed[k] && std::abs(out[i].x - out[k].x) < half[i][0] + half[k][0] + kClearance &&
          std::abs(out[i].y - out[k].y) < half[i][1] + half[k][1] + kClearance)
        return true;
    return false;
  };
  // Where a displaced object may stand: on the table and in the workspace with its whole footprint, in
  // the arm's reach, and on no named region (an object starting on its target would hold the goal).
  auto allowed = [&](std::size_t i) {
    const Placement& p = out[i];
    for (int a = 0; a < 2; ++a) {
      const double v = a == 0 ? p.x : p.y;
      const double lo = std::max(-scene.table_size[a] / 2, scene.workspace_min[a]);
      const double hi = std::min(scene.table_size[a] / 2, scene.workspace_max[a]);
      if (v - half[i][a] < lo || v + half[i][a] > hi) return false;
    }
    const double reach = std::hypot(p.x - scene.robot_base[0], p.y - scene.robot_base[1]);
    if (reach < kPosMinReach || reach > kPosMaxReach) return false;
    for (const TableRegion& r : scene.regions)
      if (std::abs(p.x - r.xy[0]) < half[i][0] + r.half[0] && std::abs(p.y - r.xy[1]) < half[i][1] + r.half[1])
        return false;
    return true;
  };
  const double radius = scene.pos.empty() ? 0 : scene.pos.magnitude_for(seed) * scene.pos.reach_m;
  // One entity: `attempts` draws until it stands clear (and, displaced, where it may).
  auto place = [&](std::size_t i, int attempts) {
    const EntitySpec& e = scene.entities[i];
    const bool displaced = !e.fixture() && radius > 0;
    const auto fp = e.asset.footprint();
    for (int attempt = 0; attempt < attempts && !placed[i]; ++attempt) {
      double dx, dy;
      if (displaced) {  // uniform on the disc
        const double r = radius * std::sqrt(0.5 * (uniform_pm1(rng()) + 1)), a = std::numbers::pi * uniform_pm1(rng());
        dx = r * std::cos(a);
        dy = r * std::sin(a);
      } else {
        dx = e.jitter * uniform_pm1(rng());
        dy = e.jitter * uniform_pm1(rng());
      }
      const double yaw = e.yaw + e.yaw_jitter * uniform_pm1(rng());
      out[i] = {e.name, e.nominal_xy[0] + dx, e.nominal_xy[1] + dy, yaw};
      const double c = std::abs(std::cos(yaw)), s = std::abs(std::sin(yaw));
      half[i] = {c * fp[0] + s * fp[1], s * fp[0] + c * fp[1]};
      placed[i] = !overlaps(i) && (!displaced || allowed(i));
      if (e.fixture()) break;
    }
    return placed[i];
  };
  auto cannot = [&](std::size_t i) {
    return std::runtime_error(scene.file.string() + ": cannot place '" + scene.entities[i].name +
                              "' without overlap for seed " + std::to_string(seed) +
                              (radius > 0 ? " within " + std::to_string(radius) + " m of its place (" + scene.pos.text() +
                                                "): lower the magnitude or reach_m in configs/suites/pos/positions.yaml"
                                          : "; widen its jitter or move its xy"));
  };
  // Fixtures first (they do not move), then free objects in scene order.
  for (std::size_t i = 0; i < n; ++i)
    if (scene.entities[i].fixture() && !place(i, 1)) throw cannot(i);
  // Displaced objects may leave a later one no room: then all of them are drawn again, from the same
  // stream, so a seed still gives one placement.
  const int rounds = radius > 0 ? 50 : 1;
  for (int round = 0; round < rounds; ++round) {
    std::size_t stuck = n;
    for (std::size_t i = 0; i < n && stuck == n; ++i)
      if (!scene.entities[i].fixture() && !place(i, radius > 0 ? 500 : 200)) stuck = i;
    if (stuck == n) break;
    if (round + 1 == rounds) throw cannot(stuck);
    for (std::size_t i = 0; i < n; ++i)
      if (!scene.entities[i].fixture()) placed[i] = false;
  }
  return out;
}

std::string scene_mjcf(const SceneSpec& scene, const std::vector<Placement>& placements,
                       const std::vector<BodyPair>& exclude) {
  const MjcfFragments robot = robot_mjcf(scene.robot, scene.robot_base.data(), scene.finger_friction);
  std::string x;
  x += "<mujoco model=\"dh_" + scene.name + "\">\n";
  x += "<compiler angle=\"radian\"/>\n";
  // Elliptic cones with a high impratio keep a pinched object from creeping out of the jaw.
  x += "<option timestep=\"0.002\" integrator=\"Euler\" cone=\"elliptic\" impratio=\"10\" jacobian=\"sparse\"/>\n";
  x += "<size njmax=\"1000\" nconmax=\"250\" nuserdata=\"" + std::to_string(kUserdataSize) + "\"/>\n";
  // Scene geoms also answer the arm links' contact bit (robot_model.cpp).
  x += "<default><geom conaffinity=\"3\"/></default>\n";
  // Rendering only (camera.hpp): the offscreen buffer bounds the image size; on llvmpipe a 1024² shadow
  // map without multisampling renders a 224² image 3-4x faster than MuJoCo's 4096² and 4 samples.
  // No multisampling also keeps the depth buffer one exact sample per pixel (RGB-D cameras, rgbd.hpp).
  int offwidth = 640, offheight = 480;
  for (const auto& c : scene.cameras) {
    offwidth = std::max(offwidth, c.width);
    offheight = std::max(offheight, c.height);
  }
  x += "<visual><global offwidth=\"" + std::to_string(offwidth) + "\" offheight=\"" + std::to_string(offheight) +
       "\"/><quality shadowsize=\"1024\" offsamples=\"0\"/></visual>\n";
  x += "<worldbody>\n";
  x += "<light pos=\"0 0 2\" dir=\"0 0 -1\" directional=\"true\"/>\n";
  x += "<geom name=\"floor\" type=\"plane\" size=\"3 3 0.1\" pos=\"0 0 -0.75\" rgba=\"0.3 0.3 0.3 1\"/>\n";
  const double table_half[3] = {scene.table_size[0] / 2, scene.table_size[1] / 2, scene.table_size[2] / 2};
  x += "<geom name=\"table\" type=\"box\" size=\"" + vec(table_half, 3) + "\" pos=\"0 0 " + num(-table_half[2]) +
       "\" friction=\"" + num(scene.table_friction) + " 0.02 0.001\" condim=\"4\" rgba=\"" +
       vec(scene.table_rgba.data(), 4) + "\"/>\n";
  for (const auto& r : scene.regions)
    x += "<site name=\"" + r.name + "\" type=\"box\" size=\"" + num(r.half[0]) + " " + num(r.half[1]) +
         " 0.005\" pos=\"" + num(r.xy[0]) + " " + num(r.xy[1]) + " -0.005\" rgba=\"0.2 0.8 0.2 0\" group=\"3\"/>\n";
  x += "<geom name=\"pedestal\" type=\"cylinder\" size=\"0.1 0.375\" pos=\"" + num(scene.robot_base[0]) + " " +
       num(scene.robot_base[1]) + " " + num(scene.robot_base[2] - 0.375) + "\" rgba=\"0.2 0.2 0.2 1\"/>\n";
  x += agentview_camera_xml(scene);
  for (const auto& c : scene.cameras)
    x += "<camera name=\"" + c.name + "\" pos=\"" + vec(c.pos.data(), 3) + "\" xyaxes=\"" +
         mjcf::look_at(c.pos.data(), c.look_at.data()) + "\" fovy=\"" + num(c.fovy) + "\"/>\n";
  x += robot.body;
  for (std::size_t i = 0; i < scene.entities.size(); ++i) x += entity_xml(scene.entities[i], placements.at(i));
  x += "</worldbody>\n";
  x += "<actuator>\n" + robot.actuators + "</actuator>\n";
  if (!robot.equalities.empty()) x += "<equality>\n" + robot.equalities + "</equality>\n";
  if (!exclude.empty()) {
    x += "<contact>\n";
    for (const auto& [a, b] : exclude) x += "<exclude body1=\"" + a + "\" body2=\"" + b + "\"/>\n";
    x += "</contact>\n";
  }
  x += "</mujoco>\n";
  return x;
}

}  // namespace dh::sim
