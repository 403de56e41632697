#include "dh/cap/skill.hpp"

#include <stdexcept>

namespace dh::cap {

std::string arg(const Bindings& args, const std::string& role) {
  for (const auto& [r, e] : args)
    if (r == role) return e;
  return "";
}

ParamTable::ParamTable(std::string capability, std::initializer_list<std::pair<const char*, double*>> fields)
    : capability_(std::move(capability)) {
  for (const auto& [name, p] : fields) fields_.emplace_back(name, p);
}

void ParamTable::load(const Theta& theta) const {
  for (const auto& [name, value] : theta) {
    bool found = false;
    for (const auto& [n, p] : fields_)
      if (n == name) {
        *p = value;
        found = true;
      }
    if (!found) throw std::invalid_argument(capability_ + " has no parameter '" + name + "'");
  }
  // θ has no defaults in code: configs/library/<capability>.yaml gives every parameter.
  std::string missing;
  for (const auto& [n, p] : fields_)
    if (!theta.count(n)) missing += (missing.empty() ? "" : ", ") + n;
  if (!missing.empty())
    throw std::invalid_argument(capability_ + " θ lacks " + missing + " (configs/library/" + capability_ +
                                ".yaml gives every parameter)");
}

}  // namespace dh::cap
