#include "dh/perception/ports.hpp"

#include "dh/common/topics.hpp"

namespace dh::perception {

const Ports& ports() {
  using enum PortDirection;
  static const Ports p{
      {In, topics::kEpisodeRequest, "dh::msg::EpisodeRequest", dds::Qos::Episode,
       "which scene a channel runs; only requests with grounding perception are looked at"},
      {In, topics::kEpisodeResult, "dh::msg::EpisodeResult", dds::Qos::Episode, "the channel's episode is over"},
      {In, topics::kObservation, "dh::msg::Observation", dds::Qos::Observation, "when to look: step 0, then every N"},
      {In, topics::kRgbd, "dh::msg::RgbdFrame", dds::Qos::Rgbd, "the frames it asked for"},
      {Out, topics::kRgbdRequest, "dh::msg::RgbdRequest", dds::Qos::RgbdRequest, "one frame of a channel's state"},
      {Out, topics::kSceneEstimate, "dh::msg::SceneEstimate", dds::Qos::Observation,
       "per frame: the entities looked for, those seen, the latency"},
  };
  return p;
}

}  // namespace dh::perception
