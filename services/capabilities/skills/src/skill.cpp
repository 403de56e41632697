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
}

Theta ParamTable::to_map() const {
  Theta t;
  for (const auto& [n, p] : fields_) t[n] = *p;
  return t;
}

}  // namespace dh::cap
