// The process around one capability family: reads commands and observations on DDS, runs the family's
// skills, writes actions and command status, announces each capability with a liveliness lease, keeps
// the episode's keyframes, and drains on SIGTERM (refuses new commands, finishes running ones).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "dh/cap/skill.hpp"

namespace CLI {
class App;
}

namespace dh::cap {

/// Runs the family `family` (the service name is dh_cap_<family>) serving `capabilities` until a
/// shutdown signal; parses --library FILE (repeatable; default configs/library/<capability>.yaml for
/// each), --drain-timeout-s. Returns the process exit code.
int run_capability_host(int argc, char** argv, const std::string& family, std::vector<CapabilityDef> capabilities);

/// A family whose capabilities depend on options of its own (e.g. vla_act's backend): `add_options`
/// registers them on the command line (a CLI::App), `make` builds the capabilities after parsing, inside
/// the service's error handling, so a missing weight file ends the process with its reason.
int run_capability_host(int argc, char** argv, const std::string& family,
                        const std::function<void(CLI::App&)>& add_options,
                        const std::function<std::vector<CapabilityDef>()>& make);

}  // namespace dh::cap
