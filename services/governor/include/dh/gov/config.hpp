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

/// ... and with what the episode's request set: decision period, grounding and perception limits.
/// Throws ConfigError for a decision period of 0, a grounding other than state and perception, or an arm
/// that grounds from perception in a request that does not say so (the perception service would not look).
GovernorConfig for_request(GovernorConfig g, const EpisodeSpec& spec);

/// The capabilities an episode may dispatch to, which the governor waits for before it starts one: those of
/// its library that its arm does not switch off (the bare arm: vla_act alone).
std::set<std::string> needed_capabilities(const GovernorConfig& episode, const EpisodeSpec& spec);

}  // namespace dh::gov
