#include "dh/gov/registry.hpp"

#include <algorithm>
#include <set>

namespace dh::gov {

void Registry::announce(const CapabilityInfo& info) {
  for (auto& i : instances_)
    if (i.instance == info.instance) {
      i = info;
      i.alive = true;
      return;
    }
  instances_.push_back(info);
  instances_.back().alive = true;
}

void Registry::set_alive(const std::string& instance, bool alive) {
  for (auto& i : instances_)
    if (i.instance == instance) i.alive = alive;
}

const CapabilityInfo* Registry::newest_alive(const std::string& capability) const {
  const CapabilityInfo* best = nullptr;
  for (const auto& i : instances_)
    if (i.capability == capability && i.alive && !i.draining && (!best || i.started_ns > best->started_ns)) best = &i;
  return best;
}

bool Registry::known(const std::string& capability) const {
  return std::any_of(instances_.begin(), instances_.end(),
                     [&](const CapabilityInfo& i) { return i.capability == capability; });
}

bool Registry::alive(const std::string& instance) const {
  return std::any_of(instances_.begin(), instances_.end(),
                     [&](const CapabilityInfo& i) { return i.instance == instance && i.alive; });
}

std::vector<std::string> Registry::missing(const std::set<std::string>& needed) const {
  std::vector<std::string> out;
  for (const auto& c : needed)
    if (!newest_alive(c)) out.push_back(c);
  return out;
}

std::vector<std::string> Registry::alive_capabilities() const {
  std::set<std::string> names;
  for (const auto& i : instances_)
    if (i.alive && !i.draining) names.insert(i.capability);
  return {names.begin(), names.end()};
}

}  // namespace dh::gov
