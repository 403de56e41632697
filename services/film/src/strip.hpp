// The strip's and the video's pixels (OpenCV stays inside this file's .cpp).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "dh/sim/camera.hpp"

namespace dh::film {

/// Frames side by side, five to a row, each with its caption lines beneath, under a title band; written
/// as PNG. Throws std::runtime_error naming the file when it cannot be written.
void write_strip(const std::filesystem::path& png, const std::vector<std::string>& title,
                 const std::vector<sim::Image>& frames, const std::vector<std::vector<std::string>>& captions);

/// A video of equal-sized frames at the control rate (20 frames per second).
class VideoOut {
 public:
  /// Throws std::runtime_error naming the file when no encoder takes it (.webm is VP8, .mp4 MPEG-4).
  VideoOut(const std::filesystem::path& file, int width, int height);
  ~VideoOut();
  VideoOut(const VideoOut&) = delete;
  VideoOut& operator=(const VideoOut&) = delete;
  void write(const sim::Image& frame);

 private:
  struct Writer;
  std::unique_ptr<Writer> writer_;
};

}  // namespace dh::film
