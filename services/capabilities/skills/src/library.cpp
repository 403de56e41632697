#include "dh/cap/library.hpp"

#include "dh/cap/articulated.hpp"
#include "dh/cap/pick_place.hpp"
#include "dh/cap/push.hpp"
#include "dh/cap/recovery.hpp"

namespace dh::cap {

namespace {
template <class S>
CapabilityDef def(const char* name) {
  return {name, [](const Theta& t) -> std::unique_ptr<Skill> { return std::make_unique<S>(t); }};
}
}  // namespace

std::vector<CapabilityDef> pick_place_family() { return {def<PickPlaceSkill>("pick_place")}; }
std::vector<CapabilityDef> push_family() { return {def<PushSkill>("push")}; }
std::vector<CapabilityDef> slide_drawer_family() { return {def<SlideDrawerSkill>("slide_drawer")}; }
std::vector<CapabilityDef> turn_knob_family() { return {def<TurnKnobSkill>("turn_knob")}; }
std::vector<CapabilityDef> swing_door_family() { return {def<SwingDoorSkill>("swing_door")}; }
std::vector<CapabilityDef> recovery_family() {
  auto grasp = [](const char* name) {
    return CapabilityDef{name, [](const Theta& t) -> std::unique_ptr<Skill> { return std::make_unique<PickPlaceSkill>(t, true); }};
  };
  return {def<KeyframeReturnSkill>("keyframe_return"), def<ReleaseRetreatSkill>("release_retreat"), grasp("regrasp"),
          grasp("reseat")};
}

std::vector<CapabilityDef> all_capabilities() {
  std::vector<CapabilityDef> all;
  for (auto f : {pick_place_family, push_family, slide_drawer_family, turn_knob_family, swing_door_family, recovery_family})
    for (auto& d : f()) all.push_back(std::move(d));
  return all;
}

const CapabilityDef* find_capability(const std::vector<CapabilityDef>& defs, const std::string& name) {
  for (const auto& d : defs)
    if (d.name == name) return &d;
  return nullptr;
}

}  // namespace dh::cap
