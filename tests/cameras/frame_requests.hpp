// The camera tests' side of rt/dh/camera/rgbd, as perception uses it: RGB-D requests written, every frame
// published kept with the time it came, and a request waited for by its id.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dh/common/dds.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/cameraPubSubTypes.h"

namespace dh::camtest {

class FrameRequests {
 public:
  using Clock = std::chrono::steady_clock;

  explicit FrameRequests(dds::Participant& p)
      : frames_(p, topics::kRgbd, dds::Qos::Rgbd,
                {[this](const msg::RgbdFrame& f, const auto&) {
                   std::lock_guard l(m_);
                   got_.emplace_back(f, Clock::now());
                   cv_.notify_all();
                 },
                 {},
                 {}}),
        req_(p, topics::kRgbdRequest, dds::Qos::RgbdRequest) {}

  /// A camera's request reader and frame writer have matched ours.
  bool matched() const { return req_.matched() >= 1 && frames_.matched() >= 1; }

  /// Asks `camera` of `channel` for a frame and waits for the answer with `id`; `latency_ms` gets the time
  /// from the request written to the frame received.
  std::optional<msg::RgbdFrame> request(std::uint32_t channel, const std::string& camera,
                                        const std::string& id,
                                        std::chrono::milliseconds timeout = std::chrono::seconds(10),
                                        double* latency_ms = nullptr) {
    msg::RgbdRequest r;
    r.channel(channel);
    r.camera(camera);
    r.request_id(id);
    const auto sent = Clock::now();
    req_.write(r);
    std::unique_lock l(m_);
    const auto it = [&] {
      return std::find_if(got_.begin(), got_.end(),
                          [&](const auto& g) { return g.first.request_id() == id; });
    };
    if (!cv_.wait_for(l, timeout, [&] { return it() != got_.end(); })) return std::nullopt;
    if (latency_ms) *latency_ms = std::chrono::duration<double, std::milli>(it()->second - sent).count();
    return it()->first;
  }

  /// Waits until `pred` holds of the frames received so far (in the order they came), and returns it.
  template <class Pred>
  bool wait(std::chrono::milliseconds timeout, Pred pred) {
    std::unique_lock l(m_);
    return cv_.wait_for(l, timeout, [&] { return pred(frames_locked()); });
  }

  std::size_t received() const {
    std::lock_guard l(m_);
    return got_.size();
  }

 private:
  std::vector<msg::RgbdFrame> frames_locked() const {
    std::vector<msg::RgbdFrame> out;
    for (const auto& g : got_) out.push_back(g.first);
    return out;
  }

  mutable std::mutex m_;
  std::condition_variable cv_;
  std::vector<std::pair<msg::RgbdFrame, Clock::time_point>> got_;
  dds::Reader<msg::RgbdFramePubSubType> frames_;
  dds::Writer<msg::RgbdRequestPubSubType> req_;
};

}  // namespace dh::camtest
