// A capability library as an episode runs it: θ for each capability, read from a folder of descriptors,
// and the library's version, a content hash of that θ. The episode request carries both; the governor
// grounds every command with that θ, so one running capability process serves episodes under different
// libraries (the evolution loop's snapshots) and each episode's evidence names the one it ran.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "dh/cap/skill.hpp"
#include "dh/cap/theta_ranges.hpp"

namespace dh::cap {

struct LibraryTheta {
  std::string version;                 ///< "lib-" + 16 hex digits of the hash over every capability's θ
  std::map<std::string, Theta> theta;  ///< by capability
  std::map<std::string, ThetaRanges> ranges;  ///< by capability: where θ may go (the version ignores them)
  /// By capability this build serves in process: its cost model under this θ (steps), which the governor
  /// budgets its commands by. A capability without one is budgeted by its instance's announced cost.
  std::map<std::string, std::uint32_t> cost_steps;
};

/// Every descriptor (*.yaml) in `dir`. The θ of a capability this build serves in process is checked as
/// its skill checks it (every parameter, none unknown); every θ against its declared range, and against
/// the benchmark's object, fixture and asset names (configs/scenes, configs/assets: no θ is keyed to a
/// case); throws ConfigError naming the file and key.
LibraryTheta load_library_theta(const std::filesystem::path& dir);

/// The content hash of θ: by capability and parameter name, each value bit for bit; formatting, comments
/// and the order in the files do not count.
std::string library_version(const std::map<std::string, Theta>& theta);

}  // namespace dh::cap
