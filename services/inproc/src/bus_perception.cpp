#include "dh/inproc/bus_perception.hpp"

#include <mujoco/mujoco.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>
#include <stdexcept>

#include "dh/perception/colour_segmenter.hpp"
#include "dh/perception/core.hpp"
#include "dh/perception/rendered_frame.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/scene.hpp"

namespace dh::inproc {

struct BusPerception::Impl {
  sim::CamerasConfig cameras;
  perception::CoreSettings settings;  // the service's defaults, as deploy/*.yaml run it
  perception::ColourSegmenter segmenter;
  perception::CloudParams cloud;
  // A rig's GPU state lives in the context: each render and the rigs' end make it current first, since
  // another stack's context may have been made current on this thread since.
  std::unique_ptr<sim::GlContext> gl;
  std::map<std::string, std::unique_ptr<sim::CameraRig>> rigs;  ///< by camera, for `cell`'s model
  std::unique_ptr<perception::PerceptionCore> core;             ///< the current episode's
  const sim::Workcell* cell = nullptr;
  std::string episode_id;

  ~Impl() {
    if (!gl) return;
    gl->make_current();
    rigs.clear();
    gl->release();
  }

  /// A frame of `camera` showing the cell now.
  perception::RgbdFrame render(const std::string& camera) {
    if (!gl) gl = std::make_unique<sim::GlContext>();
    gl->make_current();
    auto& rig = rigs[camera];
    if (!rig || rig->model() != cell->model()) {
      const auto specs = cameras.for_scene(cell->scene().name);
      const auto spec =
          std::find_if(specs.begin(), specs.end(), [&](const auto& c) { return c.name == camera; });
      if (spec == specs.end())
        throw std::invalid_argument("perception asks for camera '" + camera + "', which " +
                                    cameras.file.string() + " does not have");
      rig.reset();
      rig = std::make_unique<sim::CameraRig>(*cell, std::vector<std::string>{camera}, spec->width,
                                             spec->height);
    }
    return perception::rendered_frame(*rig, 0, cell->model(), cell->data());
  }

  /// Answers each frame asked for at once, as the simulator would, and collects the estimates made.
  std::vector<SceneEstimate> answer(const perception::PerceptionEffects& fx, std::uint32_t step) {
    note(fx);
    std::vector<SceneEstimate> out;
    for (const auto& a : fx.asks) {
      const perception::FrameMeta meta{a.channel, a.request_id, episode_id,        a.camera,
                                       "",        step,         cell->data()->time};
      const auto got = core->on_frame(meta, [&] { return render(a.camera); });
      note(got);
      if (got.estimate) out.push_back(perception::scene_estimate(*got.estimate));
    }
    return out;
  }

  void note(const perception::PerceptionEffects& fx) const {
    for (const auto& n : fx.notes)
      if (n.level != perception::Note::Level::Info) spdlog::warn("in-process perception: {}", n.text);
  }
};

BusPerception::BusPerception(const std::filesystem::path& config_dir) : impl_(std::make_unique<Impl>()) {
  impl_->cameras = sim::load_cameras_config(config_dir / "cameras.yaml");
  impl_->cloud.support_z = 0;  // the workcell's table top
}

BusPerception::~BusPerception() = default;

void BusPerception::dress(sim::SceneSpec& spec) const { spec.cameras = impl_->cameras.for_scene(spec.name); }

void BusPerception::begin(const std::string& episode_id, const TaskDef& task, const sim::Workcell& cell,
                          cap::Clock::time_point now) {
  Impl& p = *impl_;
  // What the scene names, as the service looks for it (an object cell's draws are not known to it).
  const sim::SceneSpec nominal = sim::load_nominal_scene(task);
  p.core = std::make_unique<perception::PerceptionCore>(
      p.settings, [nominal](const std::string&, std::uint32_t) { return perception::free_objects(nominal); },
      [nominal](const std::string&, std::uint32_t) { return perception::articulated_parts(nominal); },
      p.segmenter, p.cloud);
  p.cell = &cell;
  p.episode_id = episode_id;
  p.note(p.core->on_episode(0, episode_id, "perception", task.suite, task.id, now));
}

std::vector<SceneEstimate> BusPerception::on_observation(const Observation& obs, cap::Clock::time_point now) {
  Impl& p = *impl_;
  if (!p.core) throw std::logic_error("in-process perception: an observation before any episode began");
  return p.answer(p.core->on_observation(0, obs.episode_id, obs.step, now), obs.step);
}

std::vector<SceneEstimate> BusPerception::on_tick(cap::Clock::time_point now, std::uint32_t step) {
  Impl& p = *impl_;
  if (!p.core) return {};
  return p.answer(p.core->on_tick(now), step);
}

std::chrono::milliseconds BusPerception::still_every() const { return impl_->settings.still_every; }

}  // namespace dh::inproc
