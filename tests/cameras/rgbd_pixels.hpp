// Reading a published RgbdFrame's pixels in the camera tests (idl/camera.idl: depth uint16 little-endian).
#pragma once

#include <cstddef>
#include <cstdint>

#include "dh/msg/camera.h"

namespace dh::camtest {

/// Depth in millimetres at pixel (row, col), 0 = no reading.
inline std::uint16_t depth_mm(const msg::RgbdFrame& f, std::size_t row, std::size_t col) {
  const std::size_t i = 2 * (row * f.width() + col);
  return static_cast<std::uint16_t>(f.depth()[i] | (f.depth()[i + 1] << 8));
}

}  // namespace dh::camtest
