// dh_cap_push: the push capability family as its own process (see dh/cap/host.hpp).
#include "dh/cap/host.hpp"
#include "dh/cap/library.hpp"

int main(int argc, char** argv) { return dh::cap::run_capability_host(argc, argv, "push", dh::cap::push_family()); }
