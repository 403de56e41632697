// θ's physical ranges (issue 16): every revisable parameter of a library entry declares, in its `ranges:`
// section, its unit, the physical range [min, max] it may take and one line on what it is and why those
// bounds. The revision search and `dh library perturb` stay inside them; a value outside is refused at
// load, as is a parameter named after a task, a scene or an object (θ is physical, never keyed to a case).
#pragma once

#include <map>
#include <set>
#include <string>

#include "dh/cap/skill.hpp"
#include "dh/common/config.hpp"

namespace dh::cap {

struct ParameterRange {
  std::string unit;  ///< m, m/s, rad, rad/s, s, steps (50 ms control steps), N, 1
  double min = 0, max = 0;
  std::string what;
};

using ThetaRanges = std::map<std::string, ParameterRange>;

/// The `ranges:` section of the descriptor `root` for its `parameters`. Throws ConfigError naming the file
/// and key: no section, a parameter without a range or a range without a parameter, an unknown unit,
/// min >= max, a step count's bound that is not a whole number >= 1, a value outside its range, an empty
/// `what`.
ThetaRanges load_theta_ranges(const ConfigNode& root, const Theta& parameters);

/// Throws ConfigError naming the file and parameter when a name in `parameters` is keyed to a case: one of
/// `case_names` (scene entities and assets) as a whole '_'-separated part of it, or a "task"/"seed"/"scene"
/// part.
void refuse_keyed_parameters(const ConfigNode& root, const Theta& parameters, const std::set<std::string>& case_names);

}  // namespace dh::cap
