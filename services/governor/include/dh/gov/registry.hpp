// The capability registry: every announced instance and whether its liveliness holds. New commands go
// to the newest live instance that is not draining (hot swap); a running command stays on the instance it
// started on, draining or not.
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dh/gov/types.hpp"

namespace dh::gov {

class Registry {
 public:
  void announce(const CapabilityInfo& info);  ///< adds or refreshes an instance (alive again)
  void set_alive(const std::string& instance, bool alive);
  /// The newest live instance of `capability` that takes new commands (not draining), or null. Valid
  /// until the next announce().
  const CapabilityInfo* newest_alive(const std::string& capability) const;
  bool known(const std::string& capability) const;
  bool alive(const std::string& instance) const;
  /// Names of capabilities with at least one live instance that takes new commands, sorted.
  std::vector<std::string> alive_capabilities() const;
  /// Those of `needed` without such an instance, sorted: what an episode waits for before it starts.
  std::vector<std::string> missing(const std::set<std::string>& needed) const;

 private:
  std::vector<CapabilityInfo> instances_;
};

}  // namespace dh::gov
