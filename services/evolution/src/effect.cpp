#include "dh/evo/effect.hpp"

#include <map>

namespace dh::evo {

std::vector<PredicateSpec> command_effect(const std::vector<std::pair<std::string, std::string>>& args,
                                          const std::vector<PredicateSpec>& goal) {
  std::map<std::string, std::string> by_role(args.begin(), args.end());
  if (const auto s = by_role.find("state"); s != by_role.end()) {
    static const std::map<std::string, std::string> predicate{
        {"open", "Open"}, {"closed", "Close"}, {"on", "TurnOn"}, {"off", "TurnOff"}};
    const auto p = predicate.find(s->second);
    if (p == predicate.end()) return {};
    for (const auto& [role, entity] : args)
      if (role != "state") return {{p->second, {entity}}};
    return {};
  }
  const auto object = by_role.find("object"), target = by_role.find("target");
  if (object == by_role.end() || target == by_role.end()) return {};
  for (const PredicateSpec& term : goal)
    if (term.args == std::vector<std::string>{object->second, target->second}) return {term};
  // A site of the target entity is named "<entity>_<site>" (stove_cook_region, cabinet_top_side).
  for (const PredicateSpec& term : goal)
    if (term.args.size() == 2 && term.args[0] == object->second &&
        term.args[1].rfind(target->second + "_", 0) == 0)
      return {term};
  return {{"On", {object->second, target->second}}};
}

}  // namespace dh::evo
