// When an RGB-D source (frames_player, rgbd_camera) publishes besides its answers to requests: every
// 1 / rate_hz seconds, never in a burst after it fell behind. rate_hz 0: never.
#pragma once

#include <algorithm>
#include <chrono>

namespace dh::frames {

class RateSchedule {
 public:
  using Clock = std::chrono::steady_clock;

  explicit RateSchedule(double rate_hz)
      : period_(rate_hz > 0
                    ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1 / rate_hz))
                    : Clock::duration::zero()) {}

  bool on() const { return period_ > Clock::duration::zero(); }
  void start(Clock::time_point now) { next_ = now + period_; }

  /// How long a source may wait for a request before its next frame is due: at most `cap`.
  std::chrono::milliseconds wait(Clock::time_point now, std::chrono::milliseconds cap) const {
    if (!on()) return cap;
    return std::clamp(std::chrono::duration_cast<std::chrono::milliseconds>(next_ - now),
                      std::chrono::milliseconds(0), cap);
  }

  /// True when a frame is due, and the next one is then a period later (a period from now if it fell behind).
  bool due(Clock::time_point now) {
    if (!on() || now < next_) return false;
    next_ += period_;
    if (next_ < now) next_ = now + period_;
    return true;
  }

 private:
  Clock::duration period_;
  Clock::time_point next_{};
};

}  // namespace dh::frames
