// The perception service's core, DDS-free (DESIGN §11): which channels to look at, when to ask for a
// frame, which frame answers which request, and the estimate made from it. An episode is looked at only
// when its request grounds in perception (rendering costs the simulator time); its first observation (or
// the request, when the observation came first) asks for a frame, then every `every_steps` steps, never
// with one already pending; a frame unanswered for `frame_timeout` is asked again. With a parts camera set
// and articulated parts in the scene, each look also asks the parts camera for a frame, unless one of it
// is still pending (a slow parts frame never holds the objects back). Each frame becomes one estimate: the
// objects camera's of the objects looked for and those seen, the parts camera's of the parts' joint
// values (one frame and one estimate with both when the two are one camera), and the time it took. The
// DDS shell (node/perception_node.cpp) carries its events and effects.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/perceived_world.hpp"
#include "dh/common/ports.hpp"
#include "dh/perception/scene_entities.hpp"

namespace dh::perception {

using Clock = std::chrono::steady_clock;

struct CoreSettings {
  std::string camera = "workcell";  ///< the camera objects are looked for in
  unsigned every_steps = 10;        ///< a frame every N control steps (and at step 0)
  std::chrono::milliseconds frame_timeout{2000};
  /// While the robot stands still (no step for this long since the last frame was asked), the camera keeps
  /// looking: another frame of the same step is asked. The verdict from perception needs frames after the
  /// hand has left the object.
  std::chrono::milliseconds still_every{250};
  /// The camera the fixtures' articulated parts are fitted in (part_fit.hpp); empty: parts are not
  /// looked at, and the governor keeps the values its observations carry.
  std::string parts_camera{};
};

/// The objects an episode of `suite` task `task` is to look for (what its scene names); throws with the
/// reason when there is no such task.
using ObjectsOf = std::function<std::vector<LookFor>(const std::string& suite, std::uint32_t task)>;

/// The articulated parts of the scene of `suite` task `task` (articulated_parts); throws as ObjectsOf.
using PartsOf = std::function<std::vector<PartModel>(const std::string& suite, std::uint32_t task)>;

struct FrameAsk {
  std::uint32_t channel = 0;
  std::string camera, request_id;
};

/// A frame's metadata: what the pixels answer.
struct FrameMeta {
  std::uint32_t channel = 0;
  std::string request_id, episode_id, camera;
  std::string error;  ///< the source could not make it
  std::uint32_t step = 0;
  double stamp_s = 0;
};

struct SceneOut {
  std::uint32_t channel = 0;
  std::string episode_id, camera;
  std::uint32_t step = 0;
  double stamp_s = 0;
  std::vector<EntityEstimate> seen;     ///< the estimates with a positive confidence
  std::vector<std::string> looked_for;  ///< every object looked for, seen or not (none in a parts frame)
  std::map<std::string, ObjectIdentity> identities;  ///< what each object looked for is
  std::vector<PartEstimate> parts;      ///< every part looked at, in the scene's order (confidence 0: not seen)
  double latency_ms = 0;                ///< segmentation and estimation, or the parts' fit, of this frame
};

/// The estimate as the governor and the capability hosts take it in (what the scene topic carries, read
/// back): each box by its bottom centre, half extents and yaw; each part's riders with the part's rotation.
SceneEstimate scene_estimate(const SceneOut& out);

struct Note {
  enum class Level { Info, Warn, Error } level = Level::Info;
  std::string text;
};

struct PerceptionEffects {
  std::vector<FrameAsk> asks;
  std::optional<SceneOut> estimate;
  std::vector<Note> notes;  ///< what the shell logs
};

class PerceptionCore {
 public:
  /// `parts_of` is asked only with a parts camera set.
  PerceptionCore(CoreSettings settings, ObjectsOf objects_of, PartsOf parts_of, Segmenter& segmenter,
                 CloudParams cloud);

  /// What the service reads and writes (README.md lists them; a test checks the list).
  static const Ports& ports();

  PerceptionEffects on_episode(std::uint32_t channel, const std::string& episode_id,
                               const std::string& grounding, const std::string& suite, std::uint32_t task,
                               Clock::time_point now);
  void on_result(std::uint32_t channel, const std::string& episode_id);
  PerceptionEffects on_observation(std::uint32_t channel, const std::string& episode_id, std::uint32_t step,
                                   Clock::time_point now);
  /// A frame from the camera topic; `pixels` makes it (a copy of megabytes) only when it answers a request.
  PerceptionEffects on_frame(const FrameMeta& meta, const std::function<RgbdFrame()>& pixels);
  /// Asks again for frames unanswered for the timeout (the robot may be waiting for them), and for another
  /// frame of a robot that has stood still for `still_every`.
  PerceptionEffects on_tick(Clock::time_point now);

 private:
  struct Channel {
    std::string episode_id;
    std::vector<LookFor> objects;
    std::vector<EntityAppearance> looked_for;
    std::vector<PartModel> parts;
    std::optional<std::uint32_t> last_step;  ///< the step of the last look asked for
    struct Pending {
      std::string request_id;
      Clock::time_point asked_at;
    };
    std::map<std::string, Pending> pending;  ///< by camera: the frame awaited
    Clock::time_point asked_at;              ///< when the last look was asked
  };
  /// A look: a frame of the objects camera, and of the parts camera unless one of it is pending.
  std::vector<FrameAsk> ask(std::uint32_t channel, Channel& ch, std::uint32_t step, Clock::time_point now);
  FrameAsk ask_camera(std::uint32_t channel, Channel& ch, const std::string& camera, Clock::time_point now);
  /// A frame's estimate: the objects from the objects camera, the parts from the parts camera. Nothing is
  /// seen when the frame cannot be made or processed (a note says why): the estimate still says what was
  /// looked for.
  SceneOut estimate(const FrameMeta& meta, Channel& ch, const std::function<RgbdFrame()>& pixels,
                    PerceptionEffects& fx);

  CoreSettings settings_;
  ObjectsOf objects_of_;
  PartsOf parts_of_;
  Segmenter& segmenter_;
  CloudParams cloud_;
  std::map<std::uint32_t, Channel> channels_;
  std::map<std::uint32_t, std::pair<std::string, std::uint32_t>>
      last_seen_;  ///< episode and step per channel
  std::uint64_t requests_ = 0;
};

}  // namespace dh::perception
