// Numbers as MJCF attribute text, shared by the robot and scene model writers.
#pragma once

#include <cmath>
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

/// The `xyaxes` of a camera at `pos` looking at `target` with the world's z up in the image (a MuJoCo
/// camera looks along its -z, x to the right, y up). `target` must not lie straight above or below.
inline std::string look_at(const double pos[3], const double target[3]) {
  double f[3] = {target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]};
  double x[3] = {f[1], -f[0], 0};  // f x z_world
  const double nx = std::hypot(x[0], x[1]);
  for (double& v : x) v /= nx;
  const double nf = std::hypot(f[0], f[1], f[2]);
  for (double& v : f) v /= nf;
  const double y[3] = {x[1] * f[2] - x[2] * f[1], x[2] * f[0] - x[0] * f[2], x[0] * f[1] - x[1] * f[0]};  // x × f
  return list(x, 3) + " " + list(y, 3);
}

}  // namespace dh::sim::mjcf
