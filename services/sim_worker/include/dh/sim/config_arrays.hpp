// Fixed-size numeric lists from YAML (positions, sizes, colours) with errors naming file and key.
#pragma once

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "dh/common/config.hpp"

namespace dh::sim {

template <std::size_t N>
std::array<double, N> get_array(const ConfigNode& n, const std::string& key) {
  const auto v = n.get<std::vector<double>>(key);
  if (v.size() != N) n.fail(key, "expected a list of " + std::to_string(N) + " numbers");
  std::array<double, N> a{};
  std::copy(v.begin(), v.end(), a.begin());
  return a;
}

}  // namespace dh::sim
