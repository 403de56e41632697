#include "dh/sim/object_variation.hpp"

#include <algorithm>
#include <cstdio>
#include <random>

#include "dh/common/config.hpp"
#include "dh/common/digest.hpp"
#include "uniform_draw.hpp"

namespace dh::sim {

namespace {

void scale_xyz(std::array<double, 3>& v, double width, double height) {
  v[0] *= width;
  v[1] *= width;
  v[2] *= height;
}

void scale_geom(GeomSpec& g, double width, double height) {
  scale_xyz(g.pos, width, height);
  switch (g.type) {
    case GeomSpec::Type::Box:
      scale_xyz(g.size, width, height);
      break;
    case GeomSpec::Type::Cylinder:
    case GeomSpec::Type::Disc:
      g.size[0] *= width;
      g.size[1] *= height;
      break;
    case GeomSpec::Type::Ring:
      g.size[0] *= width;
      g.size[2] *= height;
      break;
  }
}

void shade(std::array<double, 4>& rgba, const std::array<double, 3>& factor) {
  for (int c = 0; c < 3; ++c) rgba[c] = std::clamp(rgba[c] * factor[c], 0.0, 1.0);
}

}  // namespace

AssetSpec scaled(AssetSpec asset, double width, double height) {
  for (auto& g : asset.geoms) scale_geom(g, width, height);
  for (auto& s : asset.sites) {
    scale_xyz(s.half, width, height);
    scale_xyz(s.pos, width, height);
  }
  return asset;
}

SceneSpec vary_objects(SceneSpec scene, const ObjectSpec& object, std::uint64_t seed) {
  for (EntitySpec& e : scene.entities) {
    if (e.fixture()) continue;
    std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL ^ fnv1a64(e.name.data(), e.name.size()));
    // Every draw is made whether it is used or not, so one attribute's draw never shifts another's.
    const double take = uniform_in(rng(), 0, 1), which = uniform_in(rng(), 0, 1);
    const double width = uniform_in(rng(), object.width[0], object.width[1]);
    const double height = uniform_in(rng(), object.height[0], object.height[1]);
    const double mass = uniform_in(rng(), object.mass[0], object.mass[1]);
    std::array<double, 3> tint{};
    for (double& t : tint) t = 1.0 + object.shade * uniform_pm1(rng());

    std::string instance = e.asset.name;
    if (const auto it = object.instances.find(e.asset.name); it != object.instances.end() && take < object.instance_share) {
      const auto& others = it->second;
      instance = others[std::min(others.size() - 1, static_cast<std::size_t>(which * static_cast<double>(others.size())))];
      // Beside the asset it replaces (configs/assets/).
      const auto file = e.asset.file.parent_path() / (instance + ".yaml");
      AssetSpec other = load_asset(file);
      if (other.kind != e.asset.kind || other.fixture)
        throw ConfigError(file.string() + ": instance of '" + e.asset.name + "' must be a free object of kind '" +
                          e.asset.kind + "', not '" + other.kind + "'");
      e.asset = std::move(other);
    }
    e.asset = scaled(std::move(e.asset), width, height);
    e.asset.mass *= mass;
    shade(e.rgba, tint);
    for (auto& g : e.asset.geoms)
      if (g.rgba) shade(*g.rgba, tint);
    char text[96];
    std::snprintf(text, sizeof text, " w%.2f h%.2f m%.2f", width, height, mass);
    e.variation = instance + text;
  }
  return scene;
}

}  // namespace dh::sim
