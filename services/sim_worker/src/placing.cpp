#include "dh/sim/placing.hpp"

#include <mujoco/mujoco.h>

#include <cmath>
#include <stdexcept>

namespace dh::sim {

void place_entities(const mjModel_* m, mjData_* d, const SceneSpec& scene,
                    const std::vector<Placement>& placements) {
  if (placements.size() != scene.entities.size())
    throw std::invalid_argument("scene '" + scene.name + "' has " + std::to_string(scene.entities.size()) +
                                " entities but " + std::to_string(placements.size()) +
                                " placements were given");
  const auto joint = [&](const std::string& name) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j < 0)
      throw std::invalid_argument("the model of scene '" + scene.name + "' has no joint '" + name + "'");
    return m->jnt_qposadr[j];
  };
  for (std::size_t k = 0; k < scene.entities.size(); ++k) {
    const EntitySpec& e = scene.entities[k];
    if (e.fixture()) continue;
    const Placement& p = placements[k];
    double* q = d->qpos + joint(e.name + "_free");
    q[0] = p.x;
    q[1] = p.y;
    q[2] = 0.001;
    q[3] = std::cos(p.yaw / 2);
    q[4] = 0;
    q[5] = 0;
    q[6] = std::sin(p.yaw / 2);
  }
  for (const auto& e : scene.entities)
    for (const auto& [part, value] : e.init_joints) d->qpos[joint(part_joint(e.name, part))] = value;
}

}  // namespace dh::sim
