// The simulator's cost per 20 Hz control step against MuJoCo's own: Workcell::step (the arm controller,
// the 50 Hz safety check and 25 physics substeps) and, on the same compiled model from the same states,
// 25 bare mj_step calls with the controls held. The ratio is what DynaHarness adds over MuJoCo. MuJoCo's
// own timers split the bare steps' time: collision detection, making the constraints, the solver.
// Run: build/bin/bench_physics [scene.yaml] [steps]   (default the goal kitchen, 400 steps)
#include <mujoco/mujoco.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dh/common/paths.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

namespace {
mjtNum now_us() {
  return std::chrono::duration<mjtNum, std::micro>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

int main(int argc, char** argv) {
  using clock = std::chrono::steady_clock;
  const std::string scene =
      argc > 1 && *argv[1] ? argv[1] : (dh::paths::config_dir() / "scenes/kitchen_goal.yaml").string();
  const int steps = argc > 2 ? std::atoi(argv[2]) : 400;
  dh::sim::Workcell cell(dh::sim::load_scene(scene));
  cell.reset(21, {});
  mjModel* m = const_cast<mjModel*>(cell.model());
  mjData* bare = mj_makeData(m);
  mjcb_time = now_us;  // turns MuJoCo's timers on
  double collision = 0, make = 0, solver = 0;
  double ours = 0, mujoco = 0;
  long contacts = 0;
  for (int k = 0; k < steps; ++k) {
    // A sweep in front of the arm, down and up, turning, the jaw opening and closing.
    const double t = k * 0.05;
    const std::array<double, 7> a{
        0.6 * std::sin(0.7 * t), 0.6 * std::cos(0.5 * t),           0.5 * std::sin(0.9 * t), 0, 0,
        0.3 * std::sin(0.3 * t), std::sin(0.4 * t) > 0 ? 1.0 : -1.0};
    mj_copyData(bare, m, cell.data());
    for (mjTimerStat& timer : bare->timer) timer = mjTimerStat{};
    const auto t0 = clock::now();
    cell.step(a);
    const auto t1 = clock::now();
    for (int s = 0; s < dh::sim::kSubsteps; ++s) mj_step(m, bare);
    const auto t2 = clock::now();
    ours += std::chrono::duration<double, std::milli>(t1 - t0).count();
    mujoco += std::chrono::duration<double, std::milli>(t2 - t1).count();
    contacts += cell.data()->ncon;
    collision += bare->timer[mjTIMER_POS_COLLISION].duration / 1000;
    make += bare->timer[mjTIMER_POS_MAKE].duration / 1000;
    solver += bare->timer[mjTIMER_CONSTRAINT].duration / 1000;
  }
  mj_deleteData(bare);
  std::printf(
      "{\"scene\": \"%s\", \"steps\": %d, \"ms_per_control_step\": %.3f, \"bare_mj_step_ms_per_25\": %.3f, "
      "\"ratio\": %.3f, \"contacts_mean\": %.1f, \"mujoco_collision_ms\": %.3f, "
      "\"mujoco_make_constraints_ms\": %.3f, "
      "\"mujoco_solver_ms\": %.3f}\n",
      cell.scene().name.c_str(), steps, ours / steps, mujoco / steps, ours / mujoco,
      static_cast<double>(contacts) / steps, collision / steps, make / steps, solver / steps);
}
