// Numbers as MJCF attribute text, shared by the robot and scene model writers.
#pragma once

#include <sstream>
#include <string>

namespace dh::sim::mjcf {

/// A number with 10 significant digits (enough for the model; stable across runs).
inline std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

/// `n` numbers separated by spaces, e.g. a size or pos attribute.
inline std::string list(const double* v, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += (i ? " " : "") + num(v[i]);
  return s;
}

}  // namespace dh::sim::mjcf
