#include <iostream>

#include "commands.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/common/paths.hpp"
#include "dh/film/film.hpp"
#include "dh/inproc/replay.hpp"
#include "dh/sim/camera.hpp"

namespace dh::cli {

int cmd_film(const FilmArgs& a) {
  if (a.out.empty() && a.video.empty()) {
    std::cerr << "error: dh film writes a strip (--out F.png), a video (--video F.webm) or both; neither was given\n";
    return 2;
  }
  film::FilmOptions o;
  o.config_dir = paths::config_dir();
  o.library_dir = a.library;
  o.max_frames = a.max_frames;
  o.camera = a.camera;
  o.width = a.width;
  o.height = a.height;
  o.strip = a.out;
  o.video = a.video;
  o.allow_drift = a.allow_drift;
  film::FilmResult r;
  try {
    if (a.steps != "auto") {
      const auto steps = campaign::parse_numbers(a.steps, "--steps");
      o.steps = std::vector<std::uint32_t>(steps.begin(), steps.end());
    }
    r = film::film(a.evidence, o);
  } catch (const inproc::FingerprintMismatch& e) {
    std::cerr << "error: " << a.evidence << ": " << e.what() << "\n";
    return 4;
  } catch (const sim::RenderError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  if (a.json) {
    std::cout << film::to_json(r).dump() << "\n";
    return 0;
  }
  for (const auto& d : r.drift) std::cout << "drift (allowed): " << d << "\n";
  for (const auto& f : r.frames) {
    const auto lines = film::caption(f);
    std::cout << lines[0] << ": " << lines[1] << (lines[2].empty() ? "" : " (" + lines[2] + ")") << "\n";
  }
  if (!r.replay_identical)
    std::cout << "note: the replay departs from the record"
              << (r.diverged_at ? " at step " + std::to_string(*r.diverged_at) : std::string())
              << "; frames after it show the replay, not the episode\n";
  if (!a.out.empty()) std::cout << "strip: " << a.out << " (" << r.frames.size() << " frames)\n";
  if (!a.video.empty()) std::cout << "video: " << a.video << " (" << r.video_frames << " frames at 20/s)\n";
  return 0;
}

}  // namespace dh::cli
