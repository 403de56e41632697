// A folder of recorded RGB-D frames (the usual RealSense export: colour PNG + 16-bit depth PNG +
// intrinsics YAML), read for frames_player, which plays it on rt/dh/camera/rgbd. No DDS here.
//
// Layout (README.md in this folder has the details and an example):
//   <folder>/intrinsics.yaml   width, height, fx, fy, cx (or ppx), cy (or ppy) in pixels; optional
//                              depth_scale (metres per depth unit, default 0.001), camera (the name to
//                              publish as), pose {position: [x, y, z], orientation: [w, x, y, z]}
//                              (world_from_camera, OpenCV camera convention)
//   <folder>/color/<stem>.png  8-bit colour (RGB, RGBA or grey) registered to the depth image
//   <folder>/depth/<stem>.png  16-bit single-channel depth in raw units (x depth_scale = metres along
//                              the optical axis), 0 = no reading
// Frames pair by stem and play in the stems' lexicographic order (zero-padded numbers sort right).
// Every error is a FramesError whose message names the file (and the key) at fault.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace dh::frames {

class FramesError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr const char* kIntrinsicsFile = "intrinsics.yaml";
inline constexpr const char* kColorDir = "color";
inline constexpr const char* kDepthDir = "depth";
inline constexpr const char* kDefaultCamera = "workcell";

struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< pixels; integer (u, v) is a pixel centre
  int width = 0, height = 0;
};

/// A camera's file, `intrinsics.yaml` (README.md): the intrinsics, the name to publish as, the depth
/// scale and where the camera is. A live source may leave the intrinsics out (`has_intrinsics` false)
/// and take them from its device; given, all six (width, height, fx, fy, cx, cy) must be.
struct CameraFile {
  bool has_intrinsics = false;
  Intrinsics K;
  double depth_scale = 0.001;  ///< metres per raw depth unit
  std::string camera = kDefaultCamera;
  bool has_pose = false;
  std::array<double, 3> position{};               ///< world_from_camera translation (m)
  std::array<double, 4> orientation{1, 0, 0, 0};  ///< world_from_camera rotation, unit quaternion w x y z
};

/// Reads a camera's file. Throws FramesError naming the file and the key for: a missing or malformed
/// file, a missing or mistyped key, non-positive fx, fy, width, height or depth_scale, some of the six
/// intrinsics without the others, or a malformed pose (position not 3 numbers, orientation not 4
/// numbers of norm 1 +- 1 %).
CameraFile read_camera_file(const std::filesystem::path& file, bool intrinsics_required);

/// A recording is its folder's camera file (intrinsics always given) and its frames.
struct Recording : CameraFile {
  struct Entry {
    std::string stem;
    std::filesystem::path color, depth;
  };
  std::filesystem::path folder;
  std::vector<Entry> frames;  ///< by stem, lexicographic
};

/// Reads intrinsics.yaml and pairs color/ and depth/ PNGs by stem, without decoding any image.
/// Throws FramesError for: a missing folder, a missing or malformed intrinsics.yaml, a missing or
/// mistyped key, non-positive fx, fy, width, height or depth_scale, a malformed pose (position not 3
/// numbers, orientation not 4 numbers of norm 1 +- 1 %), a missing color/ or depth/ folder, no frames, or a
/// colour image without its depth image (or the reverse).
Recording open_recording(const std::filesystem::path& folder);

/// One decoded frame: RGB8 (row-major, top row first) and depth in millimetres (0 = no reading).
struct Frame {
  std::size_t index = 0;
  std::string stem;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::vector<std::uint16_t> depth_mm;
};

/// Decodes frame `index`. Throws FramesError naming the file when an image cannot be decoded, has a
/// size other than the intrinsics', a colour image is not 8-bit, or a depth image is not 16-bit
/// single-channel; std::out_of_range for an index past the end.
Frame read_frame(const Recording& rec, std::size_t index);

/// A raw depth value in millimetres: round(raw * depth_scale * 1000); 0 stays 0 (no reading) and a
/// value beyond 65535 mm becomes 0.
std::uint16_t raw_depth_to_mm(std::uint16_t raw, double depth_scale);

/// Depth in millimetres as the wire format wants it: uint16 little-endian, 2 octets per pixel.
std::vector<std::uint8_t> depth_le_bytes(const std::vector<std::uint16_t>& depth_mm);

}  // namespace dh::frames
