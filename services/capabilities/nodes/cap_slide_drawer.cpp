// dh_cap_slide_drawer: the slide_drawer capability family as its own process (see dh/cap/host.hpp).
#include "dh/cap/host.hpp"
#include "dh/cap/library.hpp"

int main(int argc, char** argv) { return dh::cap::run_capability_host(argc, argv, "slide_drawer", dh::cap::slide_drawer_family()); }
