#include "dh/cap/descriptor.hpp"

#include <stdexcept>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"

namespace dh::cap {

Descriptor load_descriptor(const std::filesystem::path& file, const CapabilityDef& def) {
  const ConfigNode root = ConfigNode::load_file(file);
  Descriptor d;
  d.capability = root.get<std::string>("capability");
  if (d.capability != def.name) root.fail("capability", "expected '" + def.name + "', got '" + d.capability + "'");
  d.version = root.get<std::string>("version");
  if (!def.runs.empty()) d.version += " (" + def.runs + ")";
  d.arguments = root.get<std::vector<std::string>>("arguments");
  d.preconditions = root.get<std::vector<std::string>>("preconditions");
  const ConfigNode params = root.child("parameters");
  for (const auto& k : params.keys()) d.parameters[k] = params.get<double>(k);
  d.ranges = load_theta_ranges(root, d.parameters);
  try {
    d.cost_steps = def.make(d.parameters)->cost_steps();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(file.string() + ": key 'parameters': " + e.what());
  }
  return d;
}

std::filesystem::path default_descriptor_file(const std::string& capability) {
  return paths::config_dir() / "library" / (capability + ".yaml");
}

}  // namespace dh::cap
