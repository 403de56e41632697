#include "dh/common/perceived_world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "dh/common/config.hpp"

namespace dh {

// A snapshot's fields under their own names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(PerceivedEntity, name, p, half_extents, confidence, yaw, kind, category,
                                   colour)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(PerceivedPart::Rider, name, p, q)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(PerceivedPart, name, joint, confidence, riders)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(SceneEstimate, episode_id, step, looked_for, seen, parts)

PerceptionLimits perception_limits(const ConfigNode& section) {
  PerceptionLimits l;
  l.max_age_steps = section.get<unsigned>("max_age_steps");
  l.min_confidence = section.get<double>("min_confidence");
  if (l.min_confidence < 0 || l.min_confidence > 1) section.fail("min_confidence", "must be within 0..1");
  l.wait = std::chrono::milliseconds(section.get<unsigned>("wait_ms"));
  return l;
}

nlohmann::json limits_json(const PerceptionLimits& l) {
  return {
      {"max_age_steps", l.max_age_steps}, {"min_confidence", l.min_confidence}, {"wait_ms", l.wait.count()}};
}

PerceptionLimits limits_from(const nlohmann::json& j) {
  return {j.at("max_age_steps"), j.at("min_confidence"),
          std::chrono::milliseconds(j.at("wait_ms").get<std::int64_t>())};
}

namespace {
constexpr double kHeldMarginM = 0.03;  ///< how far outside a footprint the jaw may close and still hold it
constexpr double kHandOverMarginM = 0.05;  ///< around a footprint, the hand hides part of the object
constexpr double kHandOverHeightM = 0.15;  ///< above the object's top, ditto
constexpr double kSettleXyM = 0.02;  ///< a let-go object seen this near where it was let go has fallen there
/// Another object rests on (or in) an object when its bottom centre is inside the object's footprint,
/// from this far above the object's bottom (not beside it on the table) ...
constexpr double kRestingAboveBottomM = 0.01;
constexpr double kRestingAboveTopM = 0.03;  ///< ... to this far above its top

/// The tool is over `e`'s footprint (its box turned by its yaw) grown by `margin`, at most `height` above
/// its top.
bool tool_over(const std::array<double, 3>& tool, const PerceivedEntity& e, double margin, double height) {
  const double dx = tool[0] - e.p[0], dy = tool[1] - e.p[1], c = std::cos(e.yaw), s = std::sin(e.yaw);
  return std::abs(c * dx + s * dy) < e.half_extents[0] + margin && std::abs(-s * dx + c * dy) < e.half_extents[1] + margin &&
         tool[2] < e.p[2] + 2 * e.half_extents[2] + height;
}
}  // namespace

nlohmann::json estimate_json(const SceneEstimate& e) { return e; }

SceneEstimate estimate_from(const nlohmann::json& j) {
  try {
    return j.get<SceneEstimate>();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("a scene estimate that cannot be read: ") + e.what());
  }
}

void PerceivedWorld::on_estimate(const SceneEstimate& e) {
  if (!episode_.empty() && episode_ != e.episode_id) *this = PerceivedWorld(limits_);
  episode_ = e.episode_id;
  ++frames_;
  if (!e.parts.empty() && (!parts_step_ || e.step >= *parts_step_)) {
    parts_step_ = e.step;
    for (const auto& part : e.parts) {
      if (part.confidence < limits_.min_confidence) continue;
      joints_[part.name] = part.joint;
      for (const auto& r : part.riders) riders_[r.name] = r;
    }
  }
  if (e.looked_for.empty()) return;  // a parts camera's frame: no objects in it
  if (latest_ && e.step < latest_->step) return;
  latest_ = e;
  // Where every other object is for the resting test: as this frame sees it, else as kept.
  std::map<std::string, std::array<double, 3>> bottoms;
  for (const auto& [name, s] : seen_) bottoms[name] = s.entity.p;
  for (const auto& s : e.seen)
    if (s.confidence >= limits_.min_confidence) bottoms[s.name] = s.p;
  if (held_) bottoms.erase(*held_);
  for (const auto& s : e.seen) {
    if (s.confidence < limits_.min_confidence || held_ == s.name) continue;
    auto it = seen_.find(s.name);
    if (it != seen_.end()) {
      if (it->second.step > e.step) continue;  // put down after this frame was taken
      if (hidden(s.name, it->second, s, bottoms)) continue;
    }
    seen_[s.name] = {s, e.step, false};
  }
}

bool PerceivedWorld::hidden(const std::string& name, const Seen& s, const PerceivedEntity& estimate,
                            const std::map<std::string, std::array<double, 3>>& bottoms) const {
  const PerceivedEntity& o = s.entity;
  // Let go and seen where it was let go: it fell straight down, and the frame knows how far.
  if (s.released && std::hypot(estimate.p[0] - o.p[0], estimate.p[1] - o.p[1]) < kSettleXyM) return false;
  if (tool_ && tool_over(*tool_, o, kHandOverMarginM, kHandOverHeightM)) return true;
  for (const auto& [other, q] : bottoms)
    if (other != name && tool_over(q, o, 0, kRestingAboveTopM) && q[2] > o.p[2] + kRestingAboveBottomM) return true;
  return false;
}

std::optional<PerceivedWorld::Placement> PerceivedWorld::placement(const std::string& name) const {
  const auto it = seen_.find(name);
  if (it == seen_.end()) return std::nullopt;
  return Placement{it->second.step, it->second.released};
}

void PerceivedWorld::track(const Observation& obs) {
  tool_ = obs.ee_p;
  // The hand: what the jaw let go stays where it was let go; what it closed on moves with the tool.
  if (held_ && !obs.holding()) {
    Seen& s = seen_[*held_];
    for (int i = 0; i < 3; ++i) s.entity.p[i] = obs.ee_p[i] + held_offset_[i];
    s.step = obs.step;
    s.released = true;
    held_.reset();
  }
  if (!held_ && obs.holding()) {
    double best = INFINITY;
    for (const auto& [name, s] : seen_) {
      const double d = std::hypot(obs.ee_p[0] - s.entity.p[0], obs.ee_p[1] - s.entity.p[1]);
      if (tool_over(obs.ee_p, s.entity, kHeldMarginM, kHeldMarginM) && obs.ee_p[2] > s.entity.p[2] - kHeldMarginM && d < best) {
        best = d;
        held_ = name;
      }
    }
    if (held_) {
      const PerceivedEntity& o = seen_[*held_].entity;
      const double reach = std::max(o.half_extents[0], o.half_extents[1]);
      const double d = std::hypot(o.p[0] - obs.ee_p[0], o.p[1] - obs.ee_p[1]);
      const double shrink = d > reach ? reach / d : 1;  // the jaw holds it: the tool is inside its footprint
      held_offset_ = {(o.p[0] - obs.ee_p[0]) * shrink, (o.p[1] - obs.ee_p[1]) * shrink,
                      std::min(o.p[2] - obs.ee_p[2], -0.005)};  // and above its bottom
    }
  }
}

std::optional<Unperceived> PerceivedWorld::view(Observation& obs, const std::vector<std::string>& needed) {
  if (!latest_) return Unperceived{"no scene estimate from the perception service for this episode", true};
  if (obs.step > latest_->step + limits_.max_age_steps)
    return Unperceived{"the latest scene estimate is from step " + std::to_string(latest_->step) + ", " +
                           std::to_string(obs.step - latest_->step) + " steps old (limit " +
                           std::to_string(limits_.max_age_steps) + ")",
                       true};
  track(obs);
  const auto looked_for = [&](const std::string& name) {
    return std::find(latest_->looked_for.begin(), latest_->looked_for.end(), name) != latest_->looked_for.end();
  };
  for (const auto& name : needed) {
    if (!looked_for(name) || seen_.count(name)) continue;
    std::string detail = "latest frame: step " + std::to_string(latest_->step);
    for (const auto& e : latest_->seen)
      if (e.name == name) {
        char conf[64];
        std::snprintf(conf, sizeof conf, ", confidence %.2f < %.2f", e.confidence, limits_.min_confidence);
        detail += conf;
        break;
      }
    return Unperceived{"perception has not seen '" + name + "' in this episode (" + detail + ")", false};
  }
  const auto place = [&](EntityState& e, const PerceivedEntity& seen) {
    e.half_extents = seen.half_extents;
    e.q = {std::cos(seen.yaw / 2), 0, 0, std::sin(seen.yaw / 2)};
    if (held_ == e.name)
      for (int i = 0; i < 3; ++i) e.p[i] = obs.ee_p[i] + held_offset_[i];
    else
      e.p = seen.p;
  };
  std::vector<EntityState> kept;
  std::set<std::string> observed;
  for (auto& e : obs.entities) {
    observed.insert(e.name);
    if (const auto r = riders_.find(e.name); r != riders_.end()) {
      e.p = r->second.p;
      e.q = r->second.q;
      if (const auto j = joints_.find(e.name); j != joints_.end()) e.joint = j->second;
    }
    if (!looked_for(e.name)) {
      kept.push_back(e);
      continue;
    }
    const auto it = seen_.find(e.name);
    if (it == seen_.end()) continue;
    place(e, it->second.entity);
    kept.push_back(e);
  }
  // A real cell's observation carries only its calibrated fixtures: what perception saw comes in as the
  // perception service's description names it.
  for (const auto& [name, s] : seen_) {
    if (observed.count(name) || !looked_for(name)) continue;
    EntityState e;
    e.name = name;
    e.kind = s.entity.kind;
    e.category = s.entity.category;
    e.colour = s.entity.colour;
    place(e, s.entity);
    kept.push_back(std::move(e));
  }
  obs.entities = std::move(kept);
  return std::nullopt;
}

nlohmann::json PerceivedWorld::state() const {
  using nlohmann::json;
  json seen = json::object();
  for (const auto& [name, s] : seen_)
    seen[name] = {{"entity", s.entity}, {"step", s.step}, {"released", s.released}};
  json riders = json::array();
  for (const auto& [name, r] : riders_) riders.push_back(r);
  return {{"episode", episode_},
          {"latest", latest_ ? json(*latest_) : json(nullptr)},
          {"seen", std::move(seen)},
          {"riders", std::move(riders)},
          {"joints", joints_},
          {"parts_step", parts_step_ ? json(*parts_step_) : json(nullptr)},
          {"held", held_ ? json(*held_) : json(nullptr)},
          {"held_offset", held_offset_},
          {"tool", tool_ ? json(*tool_) : json(nullptr)},
          {"frames", frames_}};
}

PerceivedWorld PerceivedWorld::from_state(const nlohmann::json& j, PerceptionLimits limits) {
  PerceivedWorld w(limits);
  try {
    w.episode_ = j.at("episode").get<std::string>();
    if (!j.at("latest").is_null()) w.latest_ = j.at("latest").get<SceneEstimate>();
    for (const auto& [name, s] : j.at("seen").items())
      w.seen_[name] = {s.at("entity").get<PerceivedEntity>(), s.at("step").get<std::uint32_t>(),
                       s.at("released").get<bool>()};
    for (const auto& r : j.at("riders")) {
      auto rider = r.get<PerceivedPart::Rider>();
      w.riders_[rider.name] = std::move(rider);
    }
    w.joints_ = j.at("joints").get<std::map<std::string, double>>();
    if (!j.at("parts_step").is_null()) w.parts_step_ = j.at("parts_step").get<std::uint32_t>();
    if (!j.at("held").is_null()) w.held_ = j.at("held").get<std::string>();
    w.held_offset_ = j.at("held_offset").get<std::array<double, 3>>();
    if (!j.at("tool").is_null()) w.tool_ = j.at("tool").get<std::array<double, 3>>();
    w.frames_ = j.at("frames").get<std::uint32_t>();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("a perceived world's state that cannot be read: ") + e.what());
  }
  return w;
}

}  // namespace dh
