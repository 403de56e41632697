#include "dh/perception/core.hpp"

#include <algorithm>

namespace dh::perception {

PerceptionCore::PerceptionCore(CoreSettings settings, ObjectsOf objects_of, PartsOf parts_of, Segmenter& segmenter,
                               CloudParams cloud)
    : settings_(std::move(settings)),
      objects_of_(std::move(objects_of)),
      parts_of_(std::move(parts_of)),
      segmenter_(segmenter),
      cloud_(cloud) {}

const Ports& PerceptionCore::ports() {
  static const Ports p{
      in_port<port::EpisodeRequest>(
          "which scene a channel runs; only requests with grounding perception are looked at"),
      in_port<port::EpisodeResult>("the channel's episode is over"),
      in_port<port::Observation>("when to look: step 0, then every N"),
      in_port<port::Rgbd>("the frames it asked for"),
      out_port<port::RgbdRequest>("one frame of a channel's state"),
      out_port<port::SceneEstimate>("per look: the objects looked for, those seen, the parts' joint values, the latency"),
  };
  return p;
}

PerceptionEffects PerceptionCore::on_episode(std::uint32_t channel, const std::string& episode_id,
                                             const std::string& grounding, const std::string& suite,
                                             std::uint32_t task, Clock::time_point now) {
  PerceptionEffects fx;
  if (grounding != "perception") {
    channels_.erase(channel);
    return fx;
  }
  Channel& ch = channels_[channel];
  if (ch.episode_id == episode_id) return fx;  // the same request again (transient-local redelivery)
  ch = {};
  try {
    // What the scene names: an object cell's draws (size, shade, instance) are not known to perception.
    ch.objects = objects_of_(suite, task);
    if (!settings_.parts_camera.empty()) ch.parts = parts_of_(suite, task);
  } catch (const std::exception& e) {
    channels_.erase(channel);
    fx.notes.push_back({Note::Level::Error, "channel=" + std::to_string(channel) + " episode=" + episode_id +
                                                ": no scene to look for: " + e.what()});
    return fx;
  }
  ch.looked_for = appearances(ch.objects);
  ch.episode_id = episode_id;
  fx.notes.push_back({Note::Level::Info, "channel=" + std::to_string(channel) + " episode=" + episode_id +
                                             " looking for " + std::to_string(ch.looked_for.size()) +
                                             " free objects and " + std::to_string(ch.parts.size()) +
                                             (ch.parts.size() == 1 ? " part" : " parts")});
  // The simulator's first observation can come before the request does.
  const auto last = last_seen_.find(channel);
  if (last != last_seen_.end() && last->second.first == episode_id) fx.asks = ask(channel, ch, last->second.second, now);
  return fx;
}

void PerceptionCore::on_result(std::uint32_t channel, const std::string& episode_id) {
  const auto it = channels_.find(channel);
  if (it != channels_.end() && it->second.episode_id == episode_id) channels_.erase(it);
}

PerceptionEffects PerceptionCore::on_observation(std::uint32_t channel, const std::string& episode_id,
                                                 std::uint32_t step, Clock::time_point now) {
  PerceptionEffects fx;
  last_seen_[channel] = {episode_id, step};
  const auto it = channels_.find(channel);
  if (it == channels_.end() || it->second.episode_id != episode_id) return fx;
  Channel& ch = it->second;
  if (!ch.pending.empty() || (ch.last_step && step < *ch.last_step + settings_.every_steps)) return fx;
  fx.asks = ask(channel, ch, step, now);
  return fx;
}

PerceptionEffects PerceptionCore::on_frame(const FrameMeta& meta, const std::function<RgbdFrame()>& pixels) {
  PerceptionEffects fx;
  const auto it = channels_.find(meta.channel);
  if (it == channels_.end()) return fx;
  Channel& ch = it->second;
  const auto pending = ch.pending.find(meta.camera);
  if (pending == ch.pending.end() || pending->second != meta.request_id) return fx;  // not what it waits for
  if (!meta.error.empty() || (!meta.episode_id.empty() && meta.episode_id != ch.episode_id)) {
    // Asked before the simulator started the episode, or it could not render: asked again after the timeout.
    fx.notes.push_back(
        {Note::Level::Warn,
         "channel=" + std::to_string(meta.channel) + " frame " + meta.request_id + ": " +
             (meta.error.empty() ? "shows episode '" + meta.episode_id + "', not this one" : meta.error)});
    return fx;
  }
  ch.pending.erase(pending);
  estimate(meta, ch, pixels, fx);
  if (ch.pending.empty()) {
    fx.estimate = std::move(ch.look);
    ch.look.reset();
  }
  return fx;
}

void PerceptionCore::estimate(const FrameMeta& meta, Channel& ch, const std::function<RgbdFrame()>& pixels,
                              PerceptionEffects& fx) {
  const auto t0 = Clock::now();
  if (!ch.look) {
    ch.look.emplace();
    ch.look->channel = meta.channel;
    ch.look->episode_id = ch.episode_id;
    ch.look->camera = settings_.camera;
    ch.look->step = meta.step;
    ch.look->stamp_s = meta.stamp_s;
    for (const auto& a : ch.looked_for) ch.look->looked_for.push_back(a.entity);
    for (const auto& o : ch.objects) ch.look->identities[o.appearance.entity] = o.identity;
  }
  SceneOut& out = *ch.look;
  // The look is as old as its older frame.
  out.step = std::min(out.step, meta.step);
  if (meta.camera == settings_.camera) out.stamp_s = meta.stamp_s;
  try {
    const RgbdFrame frame = pixels();
    if (meta.camera == settings_.camera) {
      const auto candidates = segmenter_.segment(frame.rgb, ch.looked_for);
      const auto estimates = estimate_objects(frame, candidates, ch.objects, cloud_);
      for (std::size_t k = 0; k < estimates.size(); ++k) {
        const EntityEstimate& e = estimates[k];
        if (e.confidence <= 0) continue;
        // Identical objects keep their identities as they move (estimates come in the objects' order).
        if (e.entity == ch.objects[k].appearance.entity) ch.objects[k].prior_xy = e.centroid.head<2>();
        out.seen.push_back(e);
      }
    }
    if (meta.camera == settings_.parts_camera) out.parts = fit_parts(frame, ch.parts, {}, cloud_);
  } catch (const std::exception& e) {
    fx.notes.push_back({Note::Level::Error, "channel=" + std::to_string(meta.channel) + " frame " +
                                                meta.request_id + " not processed: " + e.what()});
  }
  out.latency_ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

PerceptionEffects PerceptionCore::on_tick(Clock::time_point now) {
  PerceptionEffects fx;
  for (auto& [id, ch] : channels_) {
    std::vector<FrameAsk> asks;
    if (!ch.pending.empty() && now - ch.asked_at >= settings_.frame_timeout) {
      for (const auto& [camera, request] : ch.pending)
        fx.notes.push_back({Note::Level::Warn, "channel=" + std::to_string(id) + " frame " + request + " of camera " +
                                                   camera + " not answered in time; asking again"});
      asks = ask(id, ch, ch.last_step.value_or(0), now);
    } else if (ch.pending.empty() && ch.last_step && now - ch.asked_at >= settings_.still_every) {
      asks = ask(id, ch, *ch.last_step, now);
    }
    fx.asks.insert(fx.asks.end(), asks.begin(), asks.end());
  }
  return fx;
}

std::vector<FrameAsk> PerceptionCore::ask(std::uint32_t channel, Channel& ch, std::uint32_t step,
                                          Clock::time_point now) {
  std::vector<FrameAsk> asks;
  ch.pending.clear();
  ch.look.reset();
  std::vector<std::string> cameras{settings_.camera};
  if (!ch.parts.empty() && settings_.parts_camera != settings_.camera) cameras.push_back(settings_.parts_camera);
  for (const auto& camera : cameras) {
    asks.push_back({channel, camera, "perception-" + std::to_string(++requests_)});
    ch.pending[camera] = asks.back().request_id;
  }
  ch.asked_at = now;
  ch.last_step = step;
  return asks;
}

}  // namespace dh::perception
