// The governor's configuration file (configs/governor.yaml) and the per-episode configuration of an arm.
#pragma once

#include <filesystem>

#include "dh/common/arms.hpp"
#include "dh/gov/episode.hpp"

namespace dh::gov {

/// Loads the fast brain's limits, timeouts and substitutions; throws ConfigError naming file and key.
GovernorConfig load_config(const std::filesystem::path& file);

/// The configuration of one episode: the defaults with the arm's mode, masked capabilities and latch.
GovernorConfig for_arm(GovernorConfig g, const ArmSpec& arm);

}  // namespace dh::gov
