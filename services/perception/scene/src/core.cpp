#include "dh/perception/core.hpp"

namespace dh::perception {

SceneEstimate scene_estimate(const SceneOut& out) {
  SceneEstimate e{out.episode_id, out.step, out.looked_for, {}, {}};
  for (const EntityEstimate& x : out.seen) {
    PerceivedEntity p{x.entity,
                      {x.centroid.x(), x.centroid.y(), x.centroid.z() - x.size.z() / 2},
                      {x.size.x() / 2, x.size.y() / 2, x.size.z() / 2},
                      x.confidence,
                      x.yaw()};
    if (const auto id = out.identities.find(x.entity); id != out.identities.end()) {
      p.kind = id->second.kind;
      p.category = id->second.category;
      p.colour = id->second.colour;
    }
    e.seen.push_back(std::move(p));
  }
  for (const PartEstimate& x : out.parts) {
    PerceivedPart part{x.name, x.joint, x.confidence, {}};
    const Eigen::Quaterniond q(x.world_from_part.rotation());
    for (const auto& [name, at] : x.riders)
      part.riders.push_back({name, {at.x(), at.y(), at.z()}, {q.w(), q.x(), q.y(), q.z()}});
    e.parts.push_back(std::move(part));
  }
  return e;
}

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
      out_port<port::SceneEstimate>("per frame: the objects looked for and those seen, or the parts' joint values; the latency"),
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
  if (ch.pending.count(settings_.camera) || (ch.last_step && step < *ch.last_step + settings_.every_steps)) return fx;
  fx.asks = ask(channel, ch, step, now);
  return fx;
}

PerceptionEffects PerceptionCore::on_frame(const FrameMeta& meta, const std::function<RgbdFrame()>& pixels) {
  PerceptionEffects fx;
  const auto it = channels_.find(meta.channel);
  if (it == channels_.end()) return fx;
  Channel& ch = it->second;
  const auto pending = ch.pending.find(meta.camera);
  if (pending == ch.pending.end() || pending->second.request_id != meta.request_id)
    return fx;  // not what this channel waits for
  if (!meta.error.empty() || (!meta.episode_id.empty() && meta.episode_id != ch.episode_id)) {
    // Asked before the simulator started the episode, or it could not render: asked again after the timeout.
    fx.notes.push_back(
        {Note::Level::Warn,
         "channel=" + std::to_string(meta.channel) + " frame " + meta.request_id + ": " +
             (meta.error.empty() ? "shows episode '" + meta.episode_id + "', not this one" : meta.error)});
    return fx;
  }
  ch.pending.erase(pending);
  fx.estimate = estimate(meta, ch, pixels, fx);
  return fx;
}

SceneOut PerceptionCore::estimate(const FrameMeta& meta, Channel& ch, const std::function<RgbdFrame()>& pixels,
                                  PerceptionEffects& fx) {
  const auto t0 = Clock::now();
  SceneOut out;
  out.channel = meta.channel;
  out.episode_id = ch.episode_id;
  out.camera = meta.camera;
  out.step = meta.step;
  out.stamp_s = meta.stamp_s;
  const bool objects = meta.camera == settings_.camera;
  try {
    const RgbdFrame frame = pixels();
    if (objects) {
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
  if (objects) {
    for (const auto& a : ch.looked_for) out.looked_for.push_back(a.entity);
    for (const auto& o : ch.objects) out.identities[o.appearance.entity] = o.identity;
  }
  out.latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return out;
}

PerceptionEffects PerceptionCore::on_tick(Clock::time_point now) {
  PerceptionEffects fx;
  for (auto& [id, ch] : channels_) {
    std::vector<std::string> late;
    for (const auto& [camera, p] : ch.pending)
      if (now - p.asked_at >= settings_.frame_timeout) late.push_back(camera);
    for (const auto& camera : late) {
      fx.notes.push_back({Note::Level::Warn, "channel=" + std::to_string(id) + " frame " +
                                                 ch.pending[camera].request_id + " of camera " + camera +
                                                 " not answered in time; asking again"});
      fx.asks.push_back(ask_camera(id, ch, camera, now));
    }
    if (!ch.pending.count(settings_.camera) && ch.last_step && now - ch.asked_at >= settings_.still_every) {
      const auto asks = ask(id, ch, *ch.last_step, now);
      fx.asks.insert(fx.asks.end(), asks.begin(), asks.end());
    }
  }
  return fx;
}

FrameAsk PerceptionCore::ask_camera(std::uint32_t channel, Channel& ch, const std::string& camera,
                                    Clock::time_point now) {
  FrameAsk a{channel, camera, "perception-" + std::to_string(++requests_)};
  ch.pending[camera] = {a.request_id, now};
  return a;
}

std::vector<FrameAsk> PerceptionCore::ask(std::uint32_t channel, Channel& ch, std::uint32_t step,
                                          Clock::time_point now) {
  std::vector<FrameAsk> asks{ask_camera(channel, ch, settings_.camera, now)};
  const std::string& parts = settings_.parts_camera;
  if (!ch.parts.empty() && parts != settings_.camera && !ch.pending.count(parts))
    asks.push_back(ask_camera(channel, ch, parts, now));
  ch.asked_at = now;
  ch.last_step = step;
  return asks;
}

}  // namespace dh::perception
