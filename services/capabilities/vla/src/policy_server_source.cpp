#include "dh/cap/policy_server_source.hpp"

#include <Eigen/Geometry>

namespace dh::cap {

void ImageCache::put(std::uint32_t channel, const std::string& episode, const std::string& camera, std::uint32_t step,
                     policy::CameraImage image) {
  std::lock_guard l(m_);
  if (auto& e = episode_[channel]; e != episode) {
    std::erase_if(latest_, [&](const auto& kv) { return kv.first.first == channel; });
    e = episode;
  }
  latest_[{channel, camera}] = {step, std::move(image)};
}

std::optional<policy::CameraImage> ImageCache::get(std::uint32_t channel, const std::string& camera,
                                                   std::uint32_t step, std::uint32_t max_age) const {
  std::lock_guard l(m_);
  const auto it = latest_.find({channel, camera});
  if (it == latest_.end() || it->second.first > step || step - it->second.first > max_age) return std::nullopt;
  return it->second.second;
}

std::array<float, 8> libero_state(const Observation& obs) {
  const Eigen::AngleAxisd aa(Eigen::Quaterniond(obs.ee_q[0], obs.ee_q[1], obs.ee_q[2], obs.ee_q[3]).normalized());
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  const auto half = static_cast<float>(obs.gripper_opening / 2);
  return {static_cast<float>(obs.ee_p[0]), static_cast<float>(obs.ee_p[1]), static_cast<float>(obs.ee_p[2]),
          static_cast<float>(r[0]), static_cast<float>(r[1]), static_cast<float>(r[2]), half, -half};
}

PolicyServerSource::PolicyServerSource(std::string url, std::chrono::milliseconds timeout,
                                       std::shared_ptr<const ImageCache> images, std::uint32_t max_image_age)
    : timeout_(timeout), client_(std::move(url), timeout), images_(std::move(images)), max_image_age_(max_image_age) {}

std::vector<policy::Action> PolicyServerSource::chunk(const Observation& obs, const std::string& instruction, double) {
  policy::PolicyQuery q;
  for (const auto& [camera, into] : {std::pair{"agentview", &q.agent_view}, std::pair{"wrist", &q.wrist}}) {
    auto image = images_->get(obs.channel, camera, obs.step, max_image_age_);
    if (!image)
      throw SourceNotReady("no '" + std::string(camera) + "' image of channel " + std::to_string(obs.channel) +
                               " within " + std::to_string(max_image_age_) + " steps of step " +
                               std::to_string(obs.step) + "; start sim_worker with --cameras agentview,wrist");
    *into = std::move(*image);
  }
  q.state = libero_state(obs);
  q.prompt = instruction;
  return client_.infer(q).actions;
}

}  // namespace dh::cap
