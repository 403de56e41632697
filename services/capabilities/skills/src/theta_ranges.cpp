#include "dh/cap/theta_ranges.hpp"

#include <cmath>
#include <sstream>

namespace dh::cap {

namespace {

const std::set<std::string>& units() {
  static const std::set<std::string> u{"m", "m/s", "rad", "rad/s", "s", "steps", "N", "1"};
  return u;
}

std::string fmt_number(double v) {
  std::string s = std::to_string(v);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

/// `name` split at '_' holds `part` as a whole run of parts ("moka_pot" in "moka_pot_lift").
bool has_part(const std::string& name, const std::string& part) {
  for (std::size_t at = name.find(part); at != std::string::npos; at = name.find(part, at + 1)) {
    const bool starts = at == 0 || name[at - 1] == '_';
    const std::size_t end = at + part.size();
    if (starts && (end == name.size() || name[end] == '_')) return true;
  }
  return false;
}

}  // namespace

ThetaRanges load_theta_ranges(const ConfigNode& root, const Theta& parameters) {
  if (!root.has("ranges"))
    root.fail("ranges", "missing: every parameter declares its unit, its physical range and what it is");
  const ConfigNode ranges = root.child("ranges");
  ThetaRanges out;
  for (const auto& name : ranges.keys()) {
    if (!parameters.count(name)) ranges.fail(name, "a range for '" + name + "', which is not one of the parameters");
    const ConfigNode r = ranges.child(name);
    ParameterRange p{r.get<std::string>("unit"), r.get<double>("min"), r.get<double>("max"), r.get<std::string>("what")};
    if (!units().count(p.unit)) r.fail("unit", "'" + p.unit + "' (known: m, m/s, rad, rad/s, s, steps, N, 1)");
    if (!(p.min < p.max)) r.fail("min", "min " + fmt_number(p.min) + " is not below max " + fmt_number(p.max));
    if (p.unit == "steps" && (p.min < 1 || std::floor(p.min) != p.min || std::floor(p.max) != p.max))
      r.fail("min", "a step count's bounds are whole numbers, at least 1");
    if (p.what.empty()) r.fail("what", "empty: say what the parameter is and why these bounds");
    const double v = parameters.at(name);
    if (v < p.min || v > p.max)
      root.fail("parameters", "'" + name + "' = " + fmt_number(v) + " " + p.unit + " lies outside its physical range [" +
                                  fmt_number(p.min) + ", " + fmt_number(p.max) + "] (ranges." + name + ")");
    out[name] = std::move(p);
  }
  for (const auto& [name, value] : parameters)
    if (!out.count(name)) ranges.fail(name, "missing: parameter '" + name + "' declares no range");
  return out;
}

void refuse_keyed_parameters(const ConfigNode& root, const Theta& parameters, const std::set<std::string>& case_names) {
  for (const auto& [name, value] : parameters) {
    std::stringstream parts(name);
    for (std::string part; std::getline(parts, part, '_');) {
      part.erase(part.find_last_not_of("0123456789") + 1);  // "task3" -> "task"
      if (part == "task" || part == "seed" || part == "scene")
        root.fail("parameters", "'" + name + "' is keyed to a " + part + ": θ is physical, the same for every case");
    }
    for (const auto& c : case_names)
      if (has_part(name, c))
        root.fail("parameters", "'" + name + "' is keyed to '" + c + "', an object or fixture of the benchmark: θ is "
                                "physical, the same for every object");
  }
}

}  // namespace dh::cap
