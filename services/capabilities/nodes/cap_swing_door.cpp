// dh_cap_swing_door: the swing_door capability family as its own process (see dh/cap/host.hpp).
#include "dh/cap/host.hpp"
#include "dh/cap/library.hpp"

int main(int argc, char** argv) { return dh::cap::run_capability_host(argc, argv, "swing_door", dh::cap::swing_door_family()); }
