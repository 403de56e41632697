// What a live RGB-D source's raw buffers become on rt/dh/camera/rgbd (idl/camera.idl RgbdFrame): colour
// rows without padding, depth in millimetres, and a pinhole's intrinsics from a device's fields of view.
// No device and no DDS here, so every rule is tested on constructed buffers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dh/frames/recording.hpp"

namespace dh::camera {

/// The units a depth buffer's uint16 values are in.
enum class DepthUnit { Millimetre, HundredMicrometre };

/// Depth rows of `stride` octets (≥ 2 × width) as millimetres along the optical axis, row-major, no
/// padding; 0 stays 0 (no reading). 100 µm values are rounded to the nearest millimetre.
std::vector<std::uint16_t> depth_mm(const void* data, int width, int height, int stride, DepthUnit unit);

/// RGB888 rows of `stride` octets (≥ 3 × width) without their padding.
std::vector<std::uint8_t> rgb_rows(const void* data, int width, int height, int stride);

/// A pinhole whose image of `width` × `height` pixels spans the fields of view (radians, full angles):
/// fx = (width / 2) / tan(hfov / 2), likewise fy, and the principal point at the image's centre,
/// ((width − 1) / 2, (height − 1) / 2) in pixel-centre coordinates. Throws std::invalid_argument when a
/// field of view is not in (0, π) (a device that does not report it: give the intrinsics in the
/// camera's file).
frames::Intrinsics intrinsics_from_fov(int width, int height, double hfov, double vfov);

}  // namespace dh::camera
