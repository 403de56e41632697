#include "dh/cap/library_theta.hpp"

#include <cstdio>
#include <cstring>
#include <set>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/library.hpp"
#include "dh/common/config.hpp"
#include "dh/common/digest.hpp"
#include "dh/common/paths.hpp"

namespace dh::cap {
namespace {

void fnv(std::uint64_t& h, const std::string& s) { h = fnv1a64(s.c_str(), s.size() + 1, h); }  // with its terminator

/// Names a θ may not be keyed to: every scene's entities and regions, every asset.
std::set<std::string> case_names() {
  std::set<std::string> names;
  const auto dir = paths::config_dir();
  for (const char* sub : {"scenes", "assets"}) {
    if (!std::filesystem::is_directory(dir / sub)) continue;
    for (const auto& entry : std::filesystem::directory_iterator(dir / sub)) {
      if (entry.path().extension() != ".yaml") continue;
      const ConfigNode root = ConfigNode::load_file(entry.path());
      if (root.has("asset")) names.insert(root.get<std::string>("asset"));
      for (const char* list : {"entities", "regions"})
        if (root.has(list))
          for (const ConfigNode& e : root.items(list)) names.insert(e.get<std::string>("name"));
    }
  }
  return names;
}

}  // namespace

std::string library_version(const std::map<std::string, Theta>& theta) {
  std::uint64_t h = kFnv1a64Basis;
  for (const auto& [capability, params] : theta) {
    fnv(h, capability);
    for (const auto& [name, value] : params) {
      fnv(h, name);
      h = fnv1a64(&value, sizeof value, h);
    }
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string("lib-") + hex;
}

LibraryTheta load_library_theta(const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir))
    throw ConfigError(dir.string() + ": no such library folder (a folder of capability descriptors, like configs/library)");
  const auto defs = all_capabilities();
  const std::set<std::string> names = case_names();
  LibraryTheta lib;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    const ConfigNode root = ConfigNode::load_file(entry.path());
    const auto name = root.get<std::string>("capability");
    if (lib.theta.count(name))
      root.fail("capability", "'" + name + "' is described twice in " + dir.string() + " (one file per capability)");
    const CapabilityDef* def = nullptr;
    for (const auto& d : defs)
      if (d.name == name) def = &d;
    if (def) {
      Descriptor d = load_descriptor(entry.path(), *def);
      lib.cost_steps[name] = static_cast<std::uint32_t>(d.cost_steps);
      lib.theta[name] = std::move(d.parameters);
      lib.ranges[name] = std::move(d.ranges);
    } else {
      // Served only by its own process here (vla_act needs its policy): read as written; its process
      // checks it when a command brings it.
      const ConfigNode params = root.child("parameters");
      for (const auto& k : params.keys()) lib.theta[name][k] = params.get<double>(k);
      lib.ranges[name] = load_theta_ranges(root, lib.theta[name]);
    }
    refuse_keyed_parameters(root, lib.theta[name], names);
  }
  if (lib.theta.empty()) throw ConfigError(dir.string() + ": no capability descriptor (*.yaml) in the library folder");
  lib.version = library_version(lib.theta);
  return lib;
}

}  // namespace dh::cap
