// A live RGB-D camera through OpenNI2 (Debian's libopenni2): any device with an OpenNI2 driver in
// OpenNI2's drivers folder -- PrimeSense and Asus Xtion (Debian's PS1080 driver), Orbbec (its OpenNI2
// SDK), Intel RealSense (librealsense's OpenNI2 wrapper, rs2driver) -- or an .oni recording. The device
// registers depth to colour; the frames come out as the wire wants them (frame_convert.hpp). No DDS here.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace dh::camera {

class SourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SourceOptions {
  std::string device;         ///< OpenNI2 URI of the device; empty: the first device found
  int width = 0, height = 0;  ///< 0: the device's current mode; both sensors must have this size
  int fps = 0;                ///< 0: any rate the size comes at
  /// true: the device maps depth onto the colour camera's pixels, or the source refuses to start; false:
  /// depth is published as the device gives it (right only for a device whose depth already is in the
  /// colour camera's frame).
  bool registration = true;
  std::chrono::milliseconds timeout{2000};  ///< a frame must come within this
};

/// One registered pair, colour and depth of the same size, captured after grab() was called.
struct LiveFrame {
  int index = 0;  ///< the depth stream's frame index
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;        ///< RGB8, row-major, no padding
  std::vector<std::uint16_t> depth_mm;  ///< millimetres along the optical axis, 0 = no reading
};

/// The devices OpenNI2 sees, one line each: URI, vendor, name. Throws SourceError when OpenNI2 cannot start.
std::vector<std::string> list_devices();

class OpenNiSource {
 public:
  /// Opens the device and starts both streams. Throws SourceError naming the device and what to do:
  /// OpenNI2 cannot start, no device (the URIs found are listed), no depth or colour sensor, no mode of
  /// the asked size, a depth or colour format it cannot publish, sizes that differ, no registration.
  explicit OpenNiSource(const SourceOptions& options);
  ~OpenNiSource();
  OpenNiSource(const OpenNiSource&) = delete;
  OpenNiSource& operator=(const OpenNiSource&) = delete;

  /// Discards what the streams hold and returns the next depth and colour frames, within one frame period
  /// of each other by the device's timestamps (the older read again, four times at most). Throws
  /// SourceError when a stream gives nothing within the timeout.
  LiveFrame grab();

  const std::string& uri() const;
  std::string describe() const;  ///< vendor, name, URI, the modes and the registration in use
  int width() const;
  int height() const;
  double hfov() const;  ///< the colour camera's, radians (0: the device does not say)
  double vfov() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dh::camera
