#include "dh/rtde/cell_entities.hpp"

#include <yaml-cpp/yaml.h>

#include <set>

#include "dh/common/config.hpp"
#include "dh/sim/config_arrays.hpp"

namespace dh::rtde {

std::vector<EntityState> load_cell_entities(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  std::vector<EntityState> out;
  std::set<std::string> names;
  const auto items = root.items("entities");
  for (const ConfigNode& n : items) {
    EntityState e;
    e.name = n.get<std::string>("name");
    e.kind = n.get<std::string>("kind");
    if (!names.insert(e.name).second) n.fail("name", "'" + e.name + "' is named twice");
    e.p = sim::get_array<3>(n, "p");
    if (n.has("q")) e.q = sim::get_array<4>(n, "q");
    e.half_extents = sim::get_array<3>(n, "half_extents");
    e.joint = n.get_or<double>("joint", 0.0);
    const bool part = e.kind == "drawer" || e.kind == "door" || e.kind == "knob";
    e.category = n.get_or<std::string>("category", e.kind == "region" ? "" : e.kind);
    e.colour = n.get_or<std::string>("colour", "");
    e.owner = n.get_or<std::string>("owner", "");
    e.relation = n.get_or<std::string>("relation", "");
    if ((part || e.kind == "region") && e.owner.empty())
      n.fail("owner", "a " + e.kind + " needs the entity it belongs to");
    if (e.kind == "region" && e.relation.empty())
      n.fail("relation", "a region needs its relation (in, on, front_of, ...)");
    out.push_back(std::move(e));
  }
  // A part's owner is a fixture of the file; a region's may be a free object, which perception names.
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].kind != "region" && !out[i].owner.empty() && !names.count(out[i].owner))
      items[i].fail("owner", "'" + out[i].owner + "' is not an entity of this file");
  return out;
}

std::optional<ArmBase> load_cell_base(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  if (!root.has("base")) return std::nullopt;
  return sim::get_array<4>(root, "base");
}

std::string cell_entities_yaml(const std::vector<EntityState>& entities, const std::optional<ArmBase>& base) {
  YAML::Emitter y;
  y.SetDoublePrecision(10);
  const auto seq = [&](const auto& values) {
    y << YAML::Flow << YAML::BeginSeq;
    for (double v : values) y << v;
    y << YAML::EndSeq;
  };
  y << YAML::BeginMap;
  if (base) {
    y << YAML::Key << "base" << YAML::Value;
    seq(*base);
  }
  y << YAML::Key << "entities" << YAML::Value << YAML::BeginSeq;
  for (const EntityState& e : entities) {
    y << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << e.name << YAML::Key << "kind"
      << YAML::Value << e.kind << YAML::Key << "p" << YAML::Value;
    seq(e.p);
    y << YAML::Key << "q" << YAML::Value;
    seq(e.q);
    y << YAML::Key << "half_extents" << YAML::Value;
    seq(e.half_extents);
    y << YAML::Key << "joint" << YAML::Value << e.joint << YAML::Key << "category" << YAML::Value << e.category
      << YAML::Key << "colour" << YAML::Value << e.colour << YAML::Key << "owner" << YAML::Value << e.owner
      << YAML::Key << "relation" << YAML::Value << e.relation << YAML::EndMap;
  }
  y << YAML::EndSeq << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

}  // namespace dh::rtde
