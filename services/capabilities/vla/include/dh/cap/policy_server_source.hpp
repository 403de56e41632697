// vla_act's `policy-server` backend: an openpi policy server (π0 / π0.5) asked over its websocket for
// each chunk, with the channel's latest agent-view and wrist images (rendered by sim_worker --cameras),
// the 8-d LIBERO state and the instruction as prompt.
#pragma once

#include <map>
#include <mutex>
#include <optional>

#include "dh/cap/vla_act.hpp"
#include "dh/policy/policy_server_client.hpp"

namespace dh::cap {

/// The latest image of each (channel, camera), filled from the camera topic, read by the skill. An image
/// of a new episode drops the channel's images of the previous one.
class ImageCache {
 public:
  void put(std::uint32_t channel, const std::string& episode, const std::string& camera, std::uint32_t step,
           policy::CameraImage image);
  /// The image of `camera` on `channel` when it shows a step at most `max_age` before `step`.
  std::optional<policy::CameraImage> get(std::uint32_t channel, const std::string& camera, std::uint32_t step,
                                         std::uint32_t max_age) const;

 private:
  mutable std::mutex m_;
  std::map<std::pair<std::uint32_t, std::string>, std::pair<std::uint32_t, policy::CameraImage>> latest_;
  std::map<std::uint32_t, std::string> episode_;  ///< channel -> episode of its images
};

/// openpi's LIBERO state: tool position, tool orientation as axis-angle, the two finger positions.
std::array<float, 8> libero_state(const Observation& obs);

class PolicyServerSource : public ActionSource {
 public:
  /// `max_image_age`: steps an image may lag the observation (sim_worker's --camera-every).
  PolicyServerSource(std::string url, std::chrono::milliseconds timeout, std::shared_ptr<const ImageCache> images,
                     std::uint32_t max_image_age);
  std::vector<policy::Action> chunk(const Observation& obs, const std::string& instruction,
                                    double gripper_command) override;
  std::string describe() const override { return "policy-server " + client_.url(); }
  std::chrono::milliseconds longest_call() const override { return timeout_; }

 private:
  std::chrono::milliseconds timeout_;
  policy::PolicyServerClient client_;
  std::shared_ptr<const ImageCache> images_;
  std::uint32_t max_image_age_;
};

}  // namespace dh::cap
