#include "dh/sim/asset.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dh/common/config.hpp"
#include "dh/sim/config_arrays.hpp"

namespace dh::sim {

namespace {

GeomSpec load_geom(const ConfigNode& n) {
  GeomSpec g;
  const auto type = n.get<std::string>("type");
  if (type == "box") g.type = GeomSpec::Type::Box;
  else if (type == "cylinder") g.type = GeomSpec::Type::Cylinder;
  else if (type == "disc") g.type = GeomSpec::Type::Disc;
  else if (type == "ring") g.type = GeomSpec::Type::Ring;
  else n.fail("type", "unknown geom type '" + type + "' (box, cylinder, disc, ring)");
  if (g.type == GeomSpec::Type::Cylinder || g.type == GeomSpec::Type::Disc) {
    const auto s = get_array<2>(n, "size");
    g.size = {s[0], s[1], 0};
  } else {
    g.size = get_array<3>(n, "size");
  }
  for (double v : g.size)
    if (v < 0) n.fail("size", "sizes are half extents and must not be negative");
  g.pos = get_array<3>(n, "pos");
  g.yaw = n.get_or<double>("yaw", 0.0);
  if (n.has("rgba")) g.rgba = get_array<4>(n, "rgba");
  g.segments = n.get_or<int>("segments", g.type == GeomSpec::Type::Disc ? 4 : 16);
  if (g.type == GeomSpec::Type::Ring && g.segments < 6) n.fail("segments", "a ring needs at least 6 segments");
  if (g.type == GeomSpec::Type::Disc && g.segments < 2) n.fail("segments", "a disc needs at least 2 boxes");
  return g;
}

SiteSpec load_site(const ConfigNode& n) {
  const auto relation = n.get<std::string>("relation");
  if (relation != "in" && relation != "on") n.fail("relation", "expected 'in' (an inside) or 'on' (a surface)");
  return {n.get<std::string>("name"), relation, get_array<3>(n, "half"), get_array<3>(n, "pos")};
}

JointSpec load_joint(const ConfigNode& n) {
  JointSpec j;
  const auto type = n.get<std::string>("type");
  if (type == "slide") j.type = JointSpec::Type::Slide;
  else if (type == "hinge") j.type = JointSpec::Type::Hinge;
  else n.fail("type", "unknown joint type '" + type + "' (slide, hinge)");
  j.axis = get_array<3>(n, "axis");
  j.range = get_array<2>(n, "range");
  if (j.range[0] >= j.range[1]) n.fail("range", "expected [lower, upper] with lower < upper");
  j.damping = n.get_or<double>("damping", 1.0);
  j.frictionloss = n.get_or<double>("frictionloss", 0.0);
  j.stiffness = n.get_or<double>("stiffness", 0.0);
  if (n.has("states")) {
    const ConfigNode st = n.child("states");
    for (const auto& name : st.keys()) j.states[name] = get_array<2>(st, name);
  }
  return j;
}

// Extent of a geom along the body's x and y axes (its bounding box half sizes) and its top/bottom z.
std::array<double, 4> extent(const GeomSpec& g) {
  const double c = std::abs(std::cos(g.yaw)), s = std::abs(std::sin(g.yaw));
  switch (g.type) {
    case GeomSpec::Type::Box:
      return {c * g.size[0] + s * g.size[1], s * g.size[0] + c * g.size[1], g.pos[2] - g.size[2], g.pos[2] + g.size[2]};
    case GeomSpec::Type::Cylinder:
    case GeomSpec::Type::Disc:
      return {g.size[0], g.size[0], g.pos[2] - g.size[1], g.pos[2] + g.size[1]};
    case GeomSpec::Type::Ring:
      return {g.size[0], g.size[0], g.pos[2] - g.size[2], g.pos[2] + g.size[2]};
  }
  return {};
}

}  // namespace

double GeomSpec::volume() const {
  switch (type) {
    case Type::Box:
      return 8 * size[0] * size[1] * size[2];
    case Type::Cylinder:
      return std::numbers::pi * size[0] * size[0] * 2 * size[1];
    // Discs and rings are emitted as boxes and MuJoCo sums the boxes' volumes, overlaps included.
    case Type::Disc: {
      const double half_angle = std::numbers::pi / (2 * segments);
      return segments * 8 * size[0] * std::cos(half_angle) * size[0] * std::sin(half_angle) * size[1];
    }
    case Type::Ring: {
      const double chord = 2 * size[0] * std::sin(std::numbers::pi / segments) + size[1] / 2;
      return segments * 8 * (size[1] / 2) * (chord / 2) * size[2];
    }
  }
  return 0;
}

std::array<double, 3> AssetSpec::half_extents() const {
  double hx = 0, hy = 0, top = 0;
  for (const auto& g : geoms) {
    const auto e = extent(g);
    hx = std::max(hx, std::abs(g.pos[0]) + e[0]);
    hy = std::max(hy, std::abs(g.pos[1]) + e[1]);
    top = std::max(top, e[3]);
  }
  return {hx, hy, top / 2};
}

std::array<double, 2> AssetSpec::footprint() const {
  auto [hx, hy, _] = half_extents();
  for (const auto& p : parts)
    for (const auto& g : p.geoms) {
      const auto e = extent(g);
      hx = std::max(hx, std::abs(p.pos[0] + g.pos[0]) + e[0]);
      hy = std::max(hy, std::abs(p.pos[1] + g.pos[1]) + e[1]);
    }
  return {hx, hy};
}

AssetSpec load_asset(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  AssetSpec a;
  a.file = file;
  a.name = root.get<std::string>("asset");
  a.kind = root.get<std::string>("kind");
  a.category = root.get_or<std::string>("category", a.kind);
  a.colour = root.get_or<std::string>("colour", "");
  a.fixture = root.get_or<bool>("fixture", false);
  a.mass = root.get_or<double>("mass", 0.0);
  if (!a.fixture && a.mass <= 0) root.fail("mass", "a free object needs a positive mass (kg)");
  a.friction = root.get_or<double>("friction", 1.0);
  a.rgba = get_array<4>(root, "rgba");
  for (const auto& g : root.items("geoms")) a.geoms.push_back(load_geom(g));
  if (a.geoms.empty()) root.fail("geoms", "an asset needs at least one geom");
  if (root.has("sites"))
    for (const auto& s : root.items("sites")) a.sites.push_back(load_site(s));
  if (root.has("parts")) {
    if (!a.fixture) root.fail("parts", "only fixtures have articulated parts");
    for (const auto& p : root.items("parts")) {
      PartSpec part;
      part.name = p.get<std::string>("name");
      part.kind = p.get<std::string>("kind");
      const ConfigNode grip = p.child("grip");
      part.grip = {"grip", "", get_array<3>(grip, "half"), get_array<3>(grip, "pos")};
      part.pos = get_array<3>(p, "pos");
      part.joint = load_joint(p.child("joint"));
      part.mass = p.get_or<double>("mass", 0.3);
      for (const auto& g : p.items("geoms")) part.geoms.push_back(load_geom(g));
      if (p.has("sites"))
        for (const auto& s : p.items("sites")) part.sites.push_back(load_site(s));
      a.parts.push_back(std::move(part));
    }
  }
  return a;
}

}  // namespace dh::sim
