// A portable uniform draw: std::uniform_real_distribution's output is implementation-defined, and a seed
// must give the same scene on every machine.
#pragma once

#include <cstdint>

namespace dh::sim {

/// In [-1, 1), from 64 random bits.
inline double uniform_pm1(std::uint64_t bits) { return 2.0 * static_cast<double>(bits >> 11) * 0x1.0p-53 - 1.0; }

/// In [low, high), from 64 random bits.
inline double uniform_in(std::uint64_t bits, double low, double high) {
  return low + (high - low) * (uniform_pm1(bits) + 1.0) / 2.0;
}

}  // namespace dh::sim
