// dh film: an episode re-run in process from its evidence (the replay, dh::inproc::replay) and rendered
// offscreen at the chosen steps into one labelled strip (PNG), and optionally every step into a video.
// What is drawn is the replay's state, so the film says whether the replay stayed bit-identical to the
// record; where it did not, the frames after the first divergence show the replay, not the episode.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dh/film/storyboard.hpp"

namespace dh::film {

struct FilmOptions {
  std::filesystem::path config_dir;   ///< suites, scenes, governor.yaml (the replay's)
  std::filesystem::path library_dir;  ///< θ compared by the replay (default config_dir/library)
  std::optional<std::vector<std::uint32_t>> steps;  ///< none: auto
  std::size_t max_frames = 8;                        ///< auto's limit
  std::string camera = "agentview";                  ///< a camera of the workcell model
  int width = 320, height = 240;                     ///< each frame
  std::filesystem::path strip;                       ///< the PNG to write
  std::filesystem::path video;                       ///< every step, when set (.webm: VP8)
  bool allow_drift = false;                          ///< film a recording of another build or θ
};

struct FilmResult {
  std::string episode_id;
  std::vector<Frame> frames;
  std::uint32_t steps = 0;             ///< steps replayed
  bool replay_identical = false;       ///< every replayed state and action as recorded
  std::optional<std::uint32_t> diverged_at;
  std::vector<std::string> drift;      ///< fingerprints that differ (with allow_drift)
  std::uint32_t video_frames = 0;
};

/// Throws std::runtime_error naming a missing or corrupt file, inproc::FingerprintMismatch when the
/// recording is of another build or θ (unless allow_drift), std::invalid_argument for a step past the
/// episode or an unknown camera, sim::RenderError when nothing can render.
FilmResult film(const std::filesystem::path& evidence, const FilmOptions& options);

nlohmann::json to_json(const FilmResult& r);

}  // namespace dh::film
