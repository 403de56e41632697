// The simulator's cost per 20 Hz control step against MuJoCo's own. From the same state before each step
// of a scripted sweep, it times Workcell::step (the arm controller, the 50 Hz safety check and 25 physics
// substeps) and 25 bare mj_step calls on three models: the workcell's own; the same scene compiled without
// the exclusions of body pairs that can never touch (contact_exclusion.hpp); and the workcell's with the
// arm links' contact bit cleared, so that only the hand and the fingers collide, as before issue 18. The
// four run one after another within each step, so a machine that slows down for a while slows them all.
// MuJoCo's timers split each bare step into collision detection, making the constraints and the solver.
// Run: build/bin/bench_physics [scene.yaml] [steps]   (default the goal kitchen, 400 steps)
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "dh/common/paths.hpp"
#include "dh/sim/model.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

namespace {
using clock_type = std::chrono::steady_clock;

mjtNum now_us() {
  return std::chrono::duration<mjtNum, std::micro>(clock_type::now().time_since_epoch()).count();
}

struct Cost {
  double step = 0, collision = 0, make = 0, solver = 0;
};

/// 25 bare substeps of `m` from the state `from` holds (a model of the same bodies and joints).
void bare_step(const mjModel* m, mjData* d, const mjModel* from_model, const mjData* from, Cost& c) {
  std::copy_n(from->qpos, from_model->nq, d->qpos);
  std::copy_n(from->qvel, from_model->nv, d->qvel);
  std::copy_n(from->act, from_model->na, d->act);
  std::copy_n(from->ctrl, from_model->nu, d->ctrl);
  std::copy_n(from->qacc_warmstart, from_model->nv, d->qacc_warmstart);
  d->time = from->time;
  for (mjTimerStat& timer : d->timer) timer = mjTimerStat{};
  const auto t0 = clock_type::now();
  for (int s = 0; s < dh::sim::kSubsteps; ++s) mj_step(m, d);
  c.step += std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
  c.collision += d->timer[mjTIMER_POS_COLLISION].duration / 1000;
  c.make += d->timer[mjTIMER_POS_MAKE].duration / 1000;
  c.solver += d->timer[mjTIMER_CONSTRAINT].duration / 1000;
}

void print(const char* name, const Cost& c, int steps, bool last = false) {
  std::printf(
      "\"%s\": {\"ms\": %.3f, \"collision_ms\": %.3f, \"make_constraints_ms\": %.3f, \"solver_ms\": %.3f}%s",
      name, c.step / steps, c.collision / steps, c.make / steps, c.solver / steps, last ? "" : ", ");
}
}  // namespace

int main(int argc, char** argv) {
  const std::string file =
      argc > 1 && *argv[1] ? argv[1] : (dh::paths::config_dir() / "scenes/kitchen_goal.yaml").string();
  const int steps = argc > 2 ? std::atoi(argv[2]) : 400;
  mjcb_time = now_us;  // turns MuJoCo's timers on
  const dh::sim::SceneSpec scene = dh::sim::load_scene(file);
  dh::sim::Workcell cell(scene);
  const mjModel* m = cell.model();
  const dh::sim::ModelPtr unfiltered =
      dh::sim::compile_model(dh::sim::scene_mjcf(scene, dh::sim::nominal_placements(scene)), file);
  const dh::sim::ModelPtr hand_only(mj_copyModel(nullptr, m));
  for (int g = 0; g < hand_only->ngeom; ++g)
    if (hand_only->geom_contype[g] == 2) hand_only->geom_contype[g] = 0;  // the arm links (robot_model.cpp)
  const dh::sim::DataPtr bare = dh::sim::make_data(m), bare_unfiltered = dh::sim::make_data(unfiltered.get()),
                         bare_hand = dh::sim::make_data(hand_only.get());
  cell.reset(21, {});
  Cost ours, own, without_exclusions, hand;
  long contacts = 0;
  for (int k = 0; k < steps; ++k) {
    // A sweep in front of the arm, down and up, turning, the jaw opening and closing.
    const double t = k * 0.05;
    // clang-format off
    const std::array<double, 7> a{0.6 * std::sin(0.7 * t), 0.6 * std::cos(0.5 * t), 0.5 * std::sin(0.9 * t),
                                  0, 0, 0.3 * std::sin(0.3 * t), std::sin(0.4 * t) > 0 ? 1.0 : -1.0};
    // clang-format on
    bare_step(m, bare.get(), m, cell.data(), own);
    bare_step(unfiltered.get(), bare_unfiltered.get(), m, cell.data(), without_exclusions);
    bare_step(hand_only.get(), bare_hand.get(), m, cell.data(), hand);
    const auto t0 = clock_type::now();
    cell.step(a);
    ours.step += std::chrono::duration<double, std::milli>(clock_type::now() - t0).count();
    contacts += cell.data()->ncon;
  }
  std::printf(
      "{\"scene\": \"%s\", \"steps\": %d, \"contacts_mean\": %.1f, \"ms_per_control_step\": %.3f, "
      "\"ratio_to_bare\": %.3f, \"exclusions\": %d, ",
      cell.scene().name.c_str(), steps, static_cast<double>(contacts) / steps, ours.step / steps,
      ours.step / own.step, m->nexclude);
  print("bare", own, steps);
  print("bare_without_exclusions", without_exclusions, steps);
  print("bare_hand_and_fingers_only", hand, steps, true);
  std::printf("}\n");
}
