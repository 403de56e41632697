// dh_cap_pick_place: the pick_place capability family as its own process (see dh/cap/host.hpp).
#include "dh/cap/host.hpp"
#include "dh/cap/library.hpp"

int main(int argc, char** argv) { return dh::cap::run_capability_host(argc, argv, "pick_place", dh::cap::pick_place_family()); }
