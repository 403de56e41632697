#include "dh/perception/ports.hpp"

namespace dh::perception {

const Ports& ports() {
  static const Ports p{
      in_port<port::EpisodeRequest>(
          "which scene a channel runs; only requests with grounding perception are looked at"),
      in_port<port::EpisodeResult>("the channel's episode is over"),
      in_port<port::Observation>("when to look: step 0, then every N"),
      in_port<port::Rgbd>("the frames it asked for"),
      out_port<port::RgbdRequest>("one frame of a channel's state"),
      out_port<port::SceneEstimate>("per frame: the entities looked for, those seen, the latency"),
  };
  return p;
}

}  // namespace dh::perception
