// Compiled workcells for episodes, by scene key (task_scene_key). A scene that every seed shares is compiled
// once and kept; an object cell's seed-varied scene is compiled for its episode and only the latest is kept,
// so a long campaign's memory does not grow with its seeds.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "dh/common/suite.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::sim {

class WorkcellCache {
 public:
  /// `dress` edits a scene before it is compiled (a simulator worker adds its RGB-D cameras).
  explicit WorkcellCache(std::function<void(SceneSpec&)> dress = {}) : dress_(std::move(dress)) {}

  struct Got {
    Workcell& cell;
    bool compiled;  ///< a new model: anything holding the previous one's pointer (a camera rig) is stale
  };
  /// The workcell for an episode of `task` with `seed` (not yet reset), with `robot` (a robot profile's
  /// name) on the scene's mount, or the scene's own arm when it is empty. On a failed compile nothing kept
  /// is dropped.
  Got get(const TaskDef& task, std::uint64_t seed, const std::string& robot = "");

 private:
  std::function<void(SceneSpec&)> dress_;
  std::map<std::string, std::unique_ptr<Workcell>> shared_;
  std::string varied_key_;
  std::unique_ptr<Workcell> varied_;
};

}  // namespace dh::sim
