#include "dh/sim/workcell_cache.hpp"

namespace dh::sim {

WorkcellCache::Got WorkcellCache::get(const TaskDef& task, std::uint64_t seed, const std::string& robot) {
  const std::string key = task_scene_key(task, seed, robot);
  const bool varied = !task.object.empty();
  if (varied ? varied_ && key == varied_key_ : shared_.contains(key))
    return {varied ? *varied_ : *shared_.at(key), false};
  SceneSpec spec = load_task_scene(task, seed, robot);
  if (dress_) dress_(spec);
  auto cell = std::make_unique<Workcell>(std::move(spec));
  if (!varied) return {*shared_.emplace(key, std::move(cell)).first->second, true};
  varied_ = std::move(cell);
  varied_key_ = key;
  return {*varied_, true};
}

}  // namespace dh::sim
