// Campaign arms: named executor configurations (the `arms` map of configs/governor.yaml). An episode
// request names its arm; the governor runs that episode with the arm's mode and masked capabilities.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace dh {

struct ArmSpec {
  std::string name;
  std::string mode;                 ///< full | static | seq | bare
  std::vector<std::string> masked;  ///< capabilities switched off in this arm
  bool latch = true;                ///< end on the latched verdict (false: the final state decides)
  std::string grounding = "state";  ///< state (the robot's observation) | perception (scene estimates)
};

/// The arms of a governor configuration; throws ConfigError naming file and key (an unknown mode, no arms).
std::map<std::string, ArmSpec> load_arms(const std::filesystem::path& governor_yaml);

/// The arm, or ConfigError listing the arms that exist.
const ArmSpec& find_arm(const std::map<std::string, ArmSpec>& arms, const std::string& name);

}  // namespace dh
