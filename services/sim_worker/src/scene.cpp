#include "dh/sim/scene.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

#include "dh/common/config.hpp"

namespace dh::sim {

namespace {

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

template <std::size_t N>
std::array<double, N> get_array(const ConfigNode& n, const std::string& key) {
  auto v = n.get<std::vector<double>>(key);
  if (v.size() != N) n.fail(key, "expected a list of " + std::to_string(N) + " numbers");
  std::array<double, N> a{};
  std::copy(v.begin(), v.end(), a.begin());
  return a;
}

ObjectSpec load_object(const ConfigNode& n) {
  ObjectSpec o;
  o.name = n.get<std::string>("name");
  o.kind_name = n.get<std::string>("kind");
  if (o.kind_name == "bowl") {
    o.kind = ObjectKind::Bowl;
    o.radius = n.get<double>("radius");
    o.height = n.get<double>("height");
    o.wall = n.get<double>("wall");
  } else if (o.kind_name == "plate") {
    o.kind = ObjectKind::Plate;
    o.radius = n.get<double>("radius");
    o.height = n.get<double>("height");
  } else if (o.kind_name == "box") {
    o.kind = ObjectKind::Box;
    o.size = get_array<3>(n, "size");
    o.height = o.size[2];
  } else if (o.kind_name == "cylinder") {
    o.kind = ObjectKind::Cylinder;
    o.radius = n.get<double>("radius");
    o.height = n.get<double>("height");
  } else {
    n.fail("kind", "unknown object kind '" + o.kind_name + "' (bowl, plate, box, cylinder)");
  }
  o.mass = n.get<double>("mass");
  if (o.mass <= 0) n.fail("mass", "must be positive (kg)");
  o.friction = n.get_or<double>("friction", 1.0);
  o.rgba = get_array<4>(n, "rgba");
  const ConfigNode place = n.child("place");
  o.nominal_xy = get_array<2>(place, "xy");
  o.jitter = place.get_or<double>("jitter", 0.0);
  o.yaw_jitter = place.get_or<double>("yaw_jitter", 0.0);
  return o;
}

std::string geom(const std::string& type, const std::string& size, const std::string& pos,
                 const std::string& quat, const ObjectSpec& o, const std::string& name) {
  return "<geom name=\"" + name + "\" type=\"" + type + "\" size=\"" + size + "\" pos=\"" + pos +
         "\" quat=\"" + quat + "\" condim=\"4\" friction=\"" + num(o.friction) +
         " 0.02 0.001\" rgba=\"" + num(o.rgba[0]) + " " + num(o.rgba[1]) + " " + num(o.rgba[2]) +
         " " + num(o.rgba[3]) + "\"/>\n";
}

std::string object_geoms(const ObjectSpec& o) {
  std::string g;
  const std::string idq = "1 0 0 0";
  switch (o.kind) {
    case ObjectKind::Bowl: {
      // A flat base and a ring of wall segments: a hollow shape whose rim a parallel jaw can pinch.
      const double base_h = o.wall;
      g += geom("cylinder", num(o.radius - o.wall / 2) + " " + num(base_h / 2),
                "0 0 " + num(base_h / 2), idq, o, o.name + "_base");
      const int n = 16;
      const double chord = 2 * o.radius * std::sin(std::numbers::pi / n) + o.wall / 2;
      const double wall_h = o.height - base_h;
      for (int i = 0; i < n; ++i) {
        const double a = 2 * std::numbers::pi * i / n;
        const double r = o.radius - o.wall / 2;
        g += geom("box", num(o.wall / 2) + " " + num(chord / 2) + " " + num(wall_h / 2),
                  num(r * std::cos(a)) + " " + num(r * std::sin(a)) + " " + num(base_h + wall_h / 2),
                  num(std::cos(a / 2)) + " 0 0 " + num(std::sin(a / 2)), o,
                  o.name + "_wall" + std::to_string(i));
      }
      break;
    }
    case ObjectKind::Plate:
    case ObjectKind::Cylinder:
      g += geom("cylinder", num(o.radius) + " " + num(o.height / 2), "0 0 " + num(o.height / 2), idq,
                o, o.name + "_geom");
      break;
    case ObjectKind::Box:
      g += geom("box", num(o.size[0] / 2) + " " + num(o.size[1] / 2) + " " + num(o.size[2] / 2),
                "0 0 " + num(o.size[2] / 2), idq, o, o.name + "_geom");
      break;
  }
  return g;
}

}  // namespace

double ObjectSpec::footprint_radius() const {
  if (kind == ObjectKind::Box) return 0.5 * std::hypot(size[0], size[1]);
  return radius;
}

std::array<double, 3> ObjectSpec::half_extents() const {
  if (kind == ObjectKind::Box) return {size[0] / 2, size[1] / 2, size[2] / 2};
  return {radius, radius, height / 2};
}

SceneSpec load_scene(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  SceneSpec s;
  s.file = file;
  s.name = root.get<std::string>("scene");
  const ConfigNode table = root.child("table");
  s.table_size = get_array<3>(table, "size");
  s.table_friction = table.get_or<double>("friction", 1.0);
  const ConfigNode robot = root.child("robot");
  s.robot = load_robot(root.dir() / robot.get<std::string>("urdf"));
  s.robot_base = get_array<3>(robot, "base");
  s.ready_q = get_array<7>(robot, "ready_q");
  s.finger_friction = robot.get_or<double>("finger_friction", 1.5);
  const ConfigNode ws = root.child("workspace");
  s.workspace_min = get_array<3>(ws, "min");
  s.workspace_max = get_array<3>(ws, "max");
  for (const ConfigNode& o : root.items("objects")) {
    ObjectSpec spec = load_object(o);
    for (const auto& other : s.objects)
      if (other.name == spec.name) o.fail("name", "object '" + spec.name + "' is defined twice");
    s.objects.push_back(std::move(spec));
  }
  return s;
}

std::vector<Placement> sample_placements(const SceneSpec& scene, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr double kClearance = 0.02;
  std::vector<Placement> out;
  for (const auto& o : scene.objects) {
    bool placed = false;
    for (int attempt = 0; attempt < 200 && !placed; ++attempt) {
      Placement p{o.name, o.nominal_xy[0] + o.jitter * u(rng), o.nominal_xy[1] + o.jitter * u(rng),
                  o.yaw_jitter * u(rng)};
      placed = true;
      for (std::size_t i = 0; i < out.size(); ++i) {
        const double d = std::hypot(p.x - out[i].x, p.y - out[i].y);
        if (d < o.footprint_radius() + scene.objects[i].footprint_radius() + kClearance) placed = false;
      }
      if (placed) out.push_back(p);
    }
    if (!placed)
      throw std::runtime_error(scene.file.string() + ": cannot place '" + o.name + "' without overlap for seed " +
                               std::to_string(seed) + "; widen its jitter or move its nominal xy");
  }
  return out;
}

std::string scene_mjcf(const SceneSpec& scene, const std::vector<Placement>& placements) {
  const MjcfFragments robot = robot_mjcf(scene.robot, scene.robot_base.data(), scene.finger_friction);
  std::string x;
  x += "<mujoco model=\"dh_" + scene.name + "\">\n";
  x += "<compiler angle=\"radian\"/>\n";
  // Elliptic cones with a high impratio keep a pinched object from creeping out of the jaw.
  x += "<option timestep=\"0.002\" integrator=\"Euler\" cone=\"elliptic\" impratio=\"10\"/>\n";
  x += "<size njmax=\"3000\" nconmax=\"800\"/>\n";
  x += "<visual><global offwidth=\"640\" offheight=\"480\"/></visual>\n";
  x += "<worldbody>\n";
  x += "<light pos=\"0 0 2\" dir=\"0 0 -1\" directional=\"true\"/>\n";
  x += "<geom name=\"floor\" type=\"plane\" size=\"3 3 0.1\" pos=\"0 0 " + num(-0.75) +
       "\" rgba=\"0.3 0.3 0.3 1\"/>\n";
  x += "<geom name=\"table\" type=\"box\" size=\"" + num(scene.table_size[0] / 2) + " " +
       num(scene.table_size[1] / 2) + " " + num(scene.table_size[2] / 2) + "\" pos=\"0 0 " +
       num(-scene.table_size[2] / 2) + "\" friction=\"" + num(scene.table_friction) +
       " 0.02 0.001\" condim=\"4\" rgba=\"0.6 0.45 0.3 1\"/>\n";
  x += "<geom name=\"pedestal\" type=\"cylinder\" size=\"0.1 0.375\" pos=\"" + num(scene.robot_base[0]) +
       " " + num(scene.robot_base[1]) + " " + num(scene.robot_base[2] - 0.375) +
       "\" rgba=\"0.2 0.2 0.2 1\"/>\n";
  x += robot.body;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const auto& o = scene.objects[i];
    const auto& p = placements.at(i);
    const double lift = 0.001;  // settle onto the table from 1 mm
    x += "<body name=\"" + o.name + "\" pos=\"" + num(p.x) + " " + num(p.y) + " " + num(lift) +
         "\" quat=\"" + num(std::cos(p.yaw / 2)) + " 0 0 " + num(std::sin(p.yaw / 2)) + "\">\n";
    x += "<freejoint name=\"" + o.name + "_free\"/>\n";
    x += "<inertial pos=\"0 0 " + num(o.height / 3) + "\" mass=\"" + num(o.mass) + "\" diaginertia=\"" +
         num(o.mass * 0.002) + " " + num(o.mass * 0.002) + " " + num(o.mass * 0.003) + "\"/>\n";
    x += object_geoms(o);
    x += "</body>\n";
  }
  x += "</worldbody>\n";
  x += "<actuator>\n" + robot.actuators + "</actuator>\n";
  if (!robot.equalities.empty()) x += "<equality>\n" + robot.equalities + "</equality>\n";
  x += "</mujoco>\n";
  return x;
}

}  // namespace dh::sim
