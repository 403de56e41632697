// A capability's library entry (configs/library/<capability>.yaml): argument schema, preconditions,
// revisable parameters θ, and the cost model its skill computes from θ.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "dh/cap/skill.hpp"
#include "dh/cap/theta_ranges.hpp"

namespace dh::cap {

struct Descriptor {
  std::string capability, version;
  std::vector<std::string> arguments;      ///< "object", or "state:open|closed" for a symbol
  std::vector<std::string> preconditions;
  Theta parameters;
  ThetaRanges ranges;  ///< every parameter's unit, physical range and meaning
  int cost_steps = 0;
};

/// Loads `file` for `def`; throws ConfigError naming the file and key (another capability's file, a
/// parameter the skill does not have, a parameter without its range or outside it: theta_ranges.hpp).
Descriptor load_descriptor(const std::filesystem::path& file, const CapabilityDef& def);

/// configs/library/<name>.yaml
std::filesystem::path default_descriptor_file(const std::string& capability);

}  // namespace dh::cap
