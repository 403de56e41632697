#include "dh/film/film.hpp"

#include <algorithm>
#include <map>
#include <memory>

#include "dh/inproc/replay.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"
#include "strip.hpp"

namespace dh::film {

FilmResult film(const std::filesystem::path& evidence, const FilmOptions& o) {
  const Storyboard story = read_storyboard(evidence);
  FilmResult result;
  result.episode_id = story.episode_id;
  result.frames = o.steps ? frames_at(story, *o.steps) : auto_frames(story, o.max_frames);

  // A camera of the model, or an RGB-D camera of configs/cameras.yaml seen from its pose (sim_worker adds
  // those to its own models only).
  std::optional<sim::CameraSpec> view;
  if (std::find(sim::workcell_cameras().begin(), sim::workcell_cameras().end(), o.camera) == sim::workcell_cameras().end()) {
    const auto file = o.config_dir / "cameras.yaml";
    const sim::CamerasConfig cameras = sim::load_cameras_config(file);
    for (const auto& c : cameras.cameras)
      if (c.camera.name == o.camera) view = c.camera;
    if (!view)
      throw std::invalid_argument("no camera '" + o.camera + "': the workcell has agentview and wrist, " + file.string() +
                                  " has " + [&] {
                                    std::string names;
                                    for (const auto& c : cameras.cameras) names += (names.empty() ? "" : ", ") + c.camera.name;
                                    return names.empty() ? std::string("none") : names;
                                  }());
  }
  std::map<std::uint32_t, sim::Image> shots;
  for (const auto& f : result.frames) shots[f.step];
  // The context outlives the rig: the rig's GPU state is freed on it.
  sim::GlContext gl;
  gl.make_current();
  std::unique_ptr<sim::CameraRig> rig;
  std::unique_ptr<VideoOut> video;
  if (!o.video.empty()) video = std::make_unique<VideoOut>(o.video, o.width, o.height);

  inproc::ReplayOptions replay{o.config_dir, o.library_dir, std::nullopt, o.allow_drift, {}};
  replay.on_step = [&](std::uint32_t step, const sim::Workcell& cell) {
    if (!rig)
      rig = std::make_unique<sim::CameraRig>(cell, std::vector<std::string>{view ? sim::kAgentviewCamera : o.camera},
                                             o.width, o.height);
    const auto shot = shots.find(step);
    if (!video && shot == shots.end()) return;
    sim::Image image;
    if (view) rig->render_from(view->pos, view->look_at, image);
    else rig->render(0, image);
    if (video) {
      video->write(image);
      ++result.video_frames;
    }
    if (shot != shots.end()) shot->second = std::move(image);
  };
  const inproc::ReplayReport report = inproc::replay(evidence, replay);
  rig.reset();
  gl.release();
  result.steps = report.steps;
  result.replay_identical = report.identical;
  if (report.first_divergence) result.diverged_at = report.first_divergence->step;
  result.drift = report.drift;

  std::vector<sim::Image> images;
  std::vector<std::vector<std::string>> captions;
  for (const auto& f : result.frames) {
    images.push_back(shots.at(f.step));
    captions.push_back(caption(f));
  }
  std::vector<std::string> title{story.episode_id + "  (" + story.arm + " arm, camera " + o.camera + ")",
                                 "\"" + story.instruction + "\"  ->  " + story.outcome};
  if (!result.replay_identical)
    title.push_back("NOTE: the replay departs from the record" +
                    (result.diverged_at ? " at step " + std::to_string(*result.diverged_at) : std::string()) +
                    "; frames after it show the replay");
  if (!o.strip.empty()) write_strip(o.strip, title, images, captions);
  return result;
}

nlohmann::json to_json(const FilmResult& r) {
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : r.frames)
    frames.push_back({{"step", f.step}, {"capability", f.capability}, {"event", f.event}, {"decision", f.decision}});
  return {{"episode_id", r.episode_id},
          {"frames", frames},
          {"steps", r.steps},
          {"replay_identical", r.replay_identical},
          {"diverged_at", r.diverged_at ? nlohmann::json(*r.diverged_at) : nlohmann::json(nullptr)},
          {"drift", r.drift},
          {"video_frames", r.video_frames}};
}

}  // namespace dh::film
