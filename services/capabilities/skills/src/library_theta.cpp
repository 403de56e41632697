#include "dh/cap/library_theta.hpp"

#include <cstdio>
#include <cstring>

#include "dh/cap/descriptor.hpp"
#include "dh/cap/library.hpp"
#include "dh/common/config.hpp"

namespace dh::cap {
namespace {

void fnv(std::uint64_t& h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
}

void fnv(std::uint64_t& h, const std::string& s) { fnv(h, s.c_str(), s.size() + 1); }  // with its terminator

}  // namespace

std::string library_version(const std::map<std::string, Theta>& theta) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const auto& [capability, params] : theta) {
    fnv(h, capability);
    for (const auto& [name, value] : params) {
      fnv(h, name);
      fnv(h, &value, sizeof value);
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
      lib.theta[name] = load_descriptor(entry.path(), *def).parameters;
    } else {
      // Served only by its own process here (vla_act needs its policy): read as written; its process
      // checks it when a command brings it.
      const ConfigNode params = root.child("parameters");
      for (const auto& k : params.keys()) lib.theta[name][k] = params.get<double>(k);
    }
  }
  if (lib.theta.empty()) throw ConfigError(dir.string() + ": no capability descriptor (*.yaml) in the library folder");
  lib.version = library_version(lib.theta);
  return lib;
}

}  // namespace dh::cap
