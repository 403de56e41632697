// The process around one capability family: reads commands and observations on DDS, runs the family's
// skills, writes actions and command status, announces each capability with a liveliness lease, keeps
// the episode's keyframes, and drains on SIGTERM (refuses new commands, finishes running ones).
#pragma once

#include <string>
#include <vector>

#include "dh/cap/skill.hpp"

namespace dh::cap {

/// Runs the family `family` (the service name is dh_cap_<family>) serving `capabilities` until a
/// shutdown signal; parses --library FILE (repeatable; default configs/library/<capability>.yaml for
/// each), --drain-timeout-s. Returns the process exit code.
int run_capability_host(int argc, char** argv, const std::string& family, std::vector<CapabilityDef> capabilities);

}  // namespace dh::cap
