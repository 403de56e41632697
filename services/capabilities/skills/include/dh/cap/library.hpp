// The capability families: which capabilities each process serves.
#pragma once

#include <string>
#include <vector>

#include "dh/cap/skill.hpp"

namespace dh::cap {

std::vector<CapabilityDef> pick_place_family();  ///< pick_place
std::vector<CapabilityDef> push_family();        ///< push
std::vector<CapabilityDef> slide_drawer_family();      ///< slide_drawer
std::vector<CapabilityDef> turn_knob_family();        ///< turn_knob
std::vector<CapabilityDef> swing_door_family();        ///< swing_door
std::vector<CapabilityDef> recovery_family();    ///< keyframe_return, release_retreat, regrasp, reseat
/// Every capability of every family (in-process runs and tests).
std::vector<CapabilityDef> all_capabilities();
/// The capability named `name` in `defs`; nullptr when there is none.
const CapabilityDef* find_capability(const std::vector<CapabilityDef>& defs, const std::string& name);

}  // namespace dh::cap
