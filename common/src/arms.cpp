#include "dh/common/arms.hpp"

#include "dh/common/config.hpp"

namespace dh {

std::map<std::string, ArmSpec> load_arms(const std::filesystem::path& governor_yaml) {
  const ConfigNode root = ConfigNode::load_file(governor_yaml);
  const ConfigNode arms = root.child("arms");
  std::map<std::string, ArmSpec> out;
  for (const auto& name : arms.keys()) {
    const ConfigNode a = arms.child(name);
    ArmSpec spec{name, a.get<std::string>("mode"), a.get_or<std::vector<std::string>>("masked_capabilities", {}),
                 a.get_or<bool>("latch", true), a.get_or<std::string>("grounding", "state")};
    if (spec.mode != "full" && spec.mode != "static" && spec.mode != "seq" && spec.mode != "bare")
      a.fail("mode", "expected full, static, seq or bare, got '" + spec.mode + "'");
    if (spec.grounding != "state" && spec.grounding != "perception")
      a.fail("grounding", "expected state or perception, got '" + spec.grounding + "'");
    out.emplace(name, std::move(spec));
  }
  if (out.empty()) root.fail("arms", "name at least one arm, e.g. full: {mode: full}");
  return out;
}

const ArmSpec& find_arm(const std::map<std::string, ArmSpec>& arms, const std::string& name) {
  const auto it = arms.find(name);
  if (it != arms.end()) return it->second;
  std::string known;
  for (const auto& [n, _] : arms) known += (known.empty() ? "" : ", ") + n;
  throw ConfigError("unknown arm '" + name + "' (arms: " + known + "; see configs/governor.yaml)");
}

}  // namespace dh
