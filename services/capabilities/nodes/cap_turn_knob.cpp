// dh_cap_turn_knob: the turn_knob capability family as its own process (see dh/cap/host.hpp).
#include "dh/cap/host.hpp"
#include "dh/cap/library.hpp"

int main(int argc, char** argv) { return dh::cap::run_capability_host(argc, argv, "turn_knob", dh::cap::turn_knob_family()); }
