// eval_parts: articulated parts' joint values from depth (part_fit.hpp) against simulator truth, without
// DDS. For each distinct (scene, seed) of the cells asked, every part of the scene's fixtures is set to
// `--draws` joint values (the scene's initial one, then uniform draws over the joint's range, the same for
// every build: a generator seeded by the seed), the arm at its ready pose; the RGB-D camera `--camera` of
// configs/cameras.yaml renders the state, and each part's joint value is fitted from the depth image.
//   eval_parts [--cells goal,goal-swap,long,long-swap,hw] [--seeds 1-10] [--draws 4] [--camera front]
//              [--csv FILE] [--save-frames DIR]
// Prints per part kind: how often it was seen (confidence at least --min-confidence), the joint error's
// median and 95th percentile, and how often a named state (open, closed, on, off) read from the fitted
// value differs from the one the true value is in: a false state (the fit says open, truth does not)
// and a missed one. And the fit's time per frame, one thread.
#include <mujoco/mujoco.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "dh/campaign/plan.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/stats.hpp"
#include "dh/common/suite.hpp"
#include "dh/perception/part_fit.hpp"
#include "dh/perception/rendered_frame.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/workcell_cache.hpp"

namespace {

using namespace dh;

/// The q-quantile, 0 for none.
double percentile(const std::vector<double>& v, double q) { return v.empty() ? 0 : stats::percentile(v, q); }

struct KindStats {
  bool slide = false;  ///< joint values in m (else rad)
  std::size_t frames = 0, seen = 0, states = 0, false_state = 0, missed_state = 0;
  std::vector<double> error;
};

bool in(const std::array<double, 2>& interval, double q) { return q >= interval[0] && q <= interval[1]; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"eval_parts: articulated parts' joint values from depth against simulator truth"};
  std::string cells = "goal,goal-swap,long,long-swap,hw", seeds = "1-10", camera = "front", save_dir;
  unsigned draws = 4;
  double min_confidence = 0.3;
  app.add_option("--cells", cells, "cells whose scenes are evaluated");
  app.add_option("--seeds", seeds, "seeds of the initial states, e.g. 1-10");
  app.add_option("--draws", draws, "joint values per part and seed: the initial one, then uniform draws")->check(CLI::Range(1u, 100u));
  app.add_option("--camera", camera, "the RGB-D camera of configs/cameras.yaml that looks");
  app.add_option("--min-confidence", min_confidence, "a fit below this counts as not seen (the governor's perception.min_confidence)");
  std::string csv_path;
  app.add_option("--csv", csv_path, "write one row per part and frame (scene, seed, draw, part, kind, truth, fit, confidence, support, through, spread) to this file");
  app.add_option("--save-frames", save_dir, "write each frame's colour image as <scene>_s<seed>_d<draw>.png into this folder");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto suites = load_suites(paths::config_dir());
    const auto cameras = sim::load_cameras_config(paths::config_dir() / "cameras.yaml");
    if (!cameras.has(camera)) throw std::runtime_error("--camera " + camera + ": configs/cameras.yaml has no such camera");
    sim::GlContext gl;
    sim::check_rendering(gl, 64, 64);
    gl.make_current();
    std::map<std::string, KindStats> by_kind;
    std::vector<double> fit_ms;
    std::set<std::string> done;
    std::ofstream csv;
    if (!csv_path.empty()) {
      csv.open(csv_path);
      if (!csv) throw std::runtime_error("--csv " + csv_path + ": cannot write it (does its folder exist?)");
      csv << "scene,seed,draw,part,kind,truth,fit,confidence,support,through,spread\n";
    }
    sim::WorkcellCache cache([&](sim::SceneSpec& s) { s.cameras = cameras.for_scene(s.name); });
    for (const auto& cell_name : campaign::parse_list(cells, "--cells")) {
      const auto suite = suites.find(cell_name);
      if (suite == suites.end()) throw std::runtime_error("--cells: no cell '" + cell_name + "' (dh tasks lists them)");
      for (const auto& [id, task] : suite->second.tasks) {
        const sim::SceneSpec spec = sim::load_nominal_scene(task);
        const auto models = perception::articulated_parts(spec);
        if (models.empty()) continue;
        for (const unsigned seed : campaign::parse_seeds(seeds)) {
          if (!done.insert(sim::task_scene_key(task, seed) + "/" + std::to_string(seed)).second) continue;
          const auto got = cache.get(task, seed);
          sim::Workcell& cell = got.cell;
          cell.reset(seed, task.goal);
          const mjModel* m = cell.model();
          mjData* d = mj_copyData(nullptr, m, cell.data());
          std::mt19937_64 rng(seed);
          sim::CameraRig rig(m, d, {camera}, 640, 480);
          for (unsigned k = 0; k < draws; ++k) {
            std::map<std::string, double> truth;
            for (const auto& part : models) {
              const int j = mj_name2id(m, mjOBJ_JOINT, (part.name + "_joint").c_str());
              if (j < 0) throw std::runtime_error("the model has no joint " + part.name + "_joint");
              double& q = d->qpos[m->jnt_qposadr[j]];
              if (k > 0) q = std::uniform_real_distribution<double>(part.lo, part.hi)(rng);
              truth[part.name] = q;
            }
            mj_forward(m, d);
            const perception::RgbdFrame frame = perception::rendered_frame(rig, 0, m, d);
            if (!save_dir.empty()) {
              std::filesystem::create_directories(save_dir);
              cv::Mat bgr;
              cv::cvtColor(frame.rgb, bgr, cv::COLOR_RGB2BGR);
              cv::imwrite((std::filesystem::path(save_dir) / (spec.name + "_s" + std::to_string(seed) + "_d" +
                                                              std::to_string(k) + ".png")).string(), bgr);
            }
            const auto t0 = std::chrono::steady_clock::now();
            const auto fits = perception::fit_parts(frame, models);
            fit_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            for (std::size_t i = 0; i < models.size(); ++i) {
              if (csv.is_open())
                csv << spec.name << ',' << seed << ',' << k << ',' << models[i].name << ',' << models[i].kind << ','
                    << truth[models[i].name] << ',' << fits[i].joint << ',' << fits[i].confidence << ','
                    << fits[i].support << ',' << fits[i].through << ',' << fits[i].spread << '\n';
              KindStats& s = by_kind[models[i].kind];
              ++s.frames;
              s.slide = models[i].joint == perception::PartModel::Joint::Slide;
              if (fits[i].confidence < min_confidence) continue;
              ++s.seen;
              const double q = truth[models[i].name];
              s.error.push_back(std::abs(fits[i].joint - q));
              // The part's named states, as the asset declares them.
              for (const auto& e : spec.entities)
                for (const auto& p : e.asset.parts) {
                  if (sim::part_body(e.name, p.name) != models[i].name) continue;
                  for (const auto& [state, interval] : p.joint.states) {
                    ++s.states;
                    const bool said = in(interval, fits[i].joint), is = in(interval, q);
                    s.false_state += said && !is;
                    s.missed_state += !said && is;
                  }
                }
            }
          }
          mj_deleteData(d);
        }
      }
    }
    std::printf("cells %s, seeds %s, %u joint values per part and seed, camera %s, 640x480\n\n", cells.c_str(),
                seeds.c_str(), draws, camera.c_str());
    std::printf("| part | frames | seen | joint error p50 | p95 | state reads | false state | missed state |\n"
                "|---|---|---|---|---|---|---|---|\n");
    for (const auto& [kind, s] : by_kind) {
      const double unit = s.slide ? 1000 : 1;
      const char* u = s.slide ? "mm" : "rad";
      std::printf("| %s | %zu | %zu | %.3g %s | %.3g %s | %zu | %zu | %zu |\n", kind.c_str(), s.frames, s.seen,
                  unit * percentile(s.error, 0.5), u, unit * percentile(s.error, 0.95), u, s.states, s.false_state,
                  s.missed_state);
    }
    std::printf("\nfit per frame (all the scene's parts), one thread: p50 %.1f ms, p99 %.1f ms\n",
                percentile(fit_ms, 0.5), percentile(fit_ms, 0.99));
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
