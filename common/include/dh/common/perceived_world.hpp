// The world as the perception service sees it, for arms that ground from perception (`grounding:
// perception`): the governor grounds and the capabilities move in it instead of in the simulator's (or
// the robot adapter's) object poses. Free objects the service looks for are placed where its frames saw
// them; fixtures and the table's regions stay where the cell's description puts them (a real cell
// calibrates those once). An articulated part the service fits (a parts camera) takes the joint value of
// its last confident fit, and its grip and the regions on it move with it; a part it does not fit, or has
// not yet fitted with confidence, keeps the observation's value. The arm's own state is proprioception.
// Pure logic, no DDS.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh {

class ConfigNode;

struct PerceivedEntity {
  std::string name;
  std::array<double, 3> p{};             ///< bottom centre of its box (m), as EntityState::p
  std::array<double, 3> half_extents{};  ///< m, along the box's own axes
  double confidence = 0;                 ///< 0..1
  double yaw = 0;                        ///< rad about world z: the box's x axis (a jaw closes across it)
  /// What it is, as the perception service's description names it (EntityState's fields of the same
  /// names): what an observation without free objects, a real cell's, takes it in as.
  std::string kind{}, category{}, colour{};
};

/// An articulated part's joint value as fitted to depth, and where it puts what rides on the part.
struct PerceivedPart {
  std::string name;  ///< as observations name the part
  double joint = 0;  ///< m or rad
  double confidence = 0;
  struct Rider {
    std::string name;  ///< the part itself (its grip) or a region on it
    std::array<double, 3> p{};
    std::array<double, 4> q{1, 0, 0, 0};
  };
  std::vector<Rider> riders;
};

/// One look's estimates from the perception service.
struct SceneEstimate {
  std::string episode_id;
  std::uint32_t step = 0;              ///< the control step of the frame
  std::vector<std::string> looked_for;  ///< every entity the service tried to find in the frame
  std::vector<PerceivedEntity> seen;    ///< those it found
  std::vector<PerceivedPart> parts{};   ///< the parts looked at (none when the service looks at no parts)
};

struct PerceptionLimits {
  std::uint32_t max_age_steps = 20;  ///< an estimate older than this (1 s at 20 Hz) is stale
  double min_confidence = 0.3;       ///< below this an entity counts as not seen
  std::chrono::milliseconds wait{3000};  ///< how long grounding waits for a fresh estimate before refusing
};

/// The `perception:` section of configs/governor.yaml ({max_age_steps, min_confidence, wait_ms}); throws
/// ConfigError naming the key.
PerceptionLimits perception_limits(const ConfigNode& section);
/// The same fields in evidence and snapshots, and read back (throws nlohmann::json's exceptions).
nlohmann::json limits_json(const PerceptionLimits& l);
PerceptionLimits limits_from(const nlohmann::json& j);

/// Why the perceived world cannot serve a step.
struct Unperceived {
  std::string reason;
  bool estimate_missing_or_stale = false;  ///< a fresh estimate may still come (worth waiting for)
};

/// One episode's perceived world on one channel. An object keeps the place of the last frame that saw it
/// unhidden: while the tool is over it, or another object rests on it, part of it is hidden and frames
/// would shift it. The object the closed jaw holds (the nearest one whose footprint, 3 cm wider, has the
/// tool over it) moves with the tool until the jaw opens; the contact corrects its perceived place so far
/// that the tool is inside its footprint and above its bottom. What the jaw let go falls: a frame that
/// sees it where it was let go (its footprint's centre within 2 cm) places it, the hand over it or not.
class PerceivedWorld {
 public:
  explicit PerceivedWorld(PerceptionLimits limits) : limits_(limits) {}
  /// The episode's limits, from its commands; frames already taken in keep the confidence filter they had.
  void set_limits(PerceptionLimits limits) { limits_ = limits; }

  /// A frame's estimates; an older frame than the latest of its kind (objects, parts) is ignored. Another
  /// episode's frame starts the world afresh.
  void on_estimate(const SceneEstimate& e);
  /// The latest frame's estimates of the objects, if any came (a parts camera's frames are not counted).
  const std::optional<SceneEstimate>& latest() const { return latest_; }
  /// The episode of the frames taken in; empty before the first.
  const std::string& episode() const { return episode_; }
  /// How many of the episode's estimates it has taken in (older frames too), in the order they came.
  std::uint32_t frames() const { return frames_; }

  /// The hand at one control step: the object the closed jaw takes moves with the tool from that step,
  /// and what it lets go stays where it was let go. Call it with every observation: the hand is tracked
  /// step by step, not only when a view is asked for (then an object let go before the view would be
  /// placed where the retreating tool is). view() tracks its observation too.
  void track(const Observation& obs);

  /// Rewrites `obs` as perception sees it: each entity the service looks for takes its perceived place,
  /// size and yaw (upright: no tilt is estimated), or leaves the scene when no frame of the episode saw it;
  /// one the observation lacks (a real cell's observation has no free objects) comes in as seen. A fitted
  /// part takes its perceived joint value and pose, and the regions on it theirs.
  /// Returns why it cannot — no estimate, a stale one, or an entity of `needed` never seen — or nullopt.
  std::optional<Unperceived> view(Observation& obs, const std::vector<std::string>& needed);

  /// Where `name`'s perceived place comes from: the step of the frame or of the release that put it
  /// there; unset when no frame saw it.
  struct Placement {
    std::uint32_t step = 0;
    bool released = false;  ///< let go by the jaw there, not seen there by a frame since
  };
  std::optional<Placement> placement(const std::string& name) const;

  /// Everything taken in so far, for an episode's snapshot: the latest frame, each object's place and
  /// where it came from, the fitted parts, the held object and the tool. Doubles round-trip exactly.
  nlohmann::json state() const;
  /// The world `state()` gave, under `limits` (the episode's); throws std::invalid_argument naming what
  /// cannot be read.
  static PerceivedWorld from_state(const nlohmann::json& state, PerceptionLimits limits);

 private:
  struct Seen {
    PerceivedEntity entity;
    std::uint32_t step = 0;  ///< the frame (or the release) it was last placed at
    bool released = false;   ///< placed by the release, not by a frame
  };
  /// Whether a frame's `estimate` may not move `s` now: the tool, or another object resting on it (the
  /// others' bottom centres in `bottoms`), hides part of it.
  bool hidden(const std::string& name, const Seen& s, const PerceivedEntity& estimate,
              const std::map<std::string, std::array<double, 3>>& bottoms) const;
  PerceptionLimits limits_;
  std::optional<SceneEstimate> latest_;
  std::map<std::string, Seen> seen_;
  std::string episode_;
  std::map<std::string, PerceivedPart::Rider> riders_;  ///< by name: the parts and regions fitted parts carry
  std::map<std::string, double> joints_;                ///< by part: its last confident joint value
  std::optional<std::uint32_t> parts_step_;             ///< the step of the latest frame with parts
  std::optional<std::string> held_;          ///< the object moving with the tool
  std::array<double, 3> held_offset_{};      ///< its bottom centre relative to the tool
  std::optional<std::array<double, 3>> tool_;  ///< the tool's position at the latest observation tracked
  std::uint32_t frames_ = 0;
};

/// An estimate in an episode's evidence (`scene_estimate` records), and read back; the latter throws
/// std::invalid_argument naming what cannot be read.
nlohmann::json estimate_json(const SceneEstimate& e);
SceneEstimate estimate_from(const nlohmann::json& j);

}  // namespace dh
