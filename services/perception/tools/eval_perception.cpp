// eval_perception: perception against simulator truth over the benchmark's scenes and seeds, without DDS.
// For each distinct (scene, seed) of the cells asked, the workcell camera of configs/cameras.yaml renders
// the initial state; the embedded pipeline (colour masks from the scene description, PCL boxes) estimates
// every free object, and each estimate's box centre is compared with the object's true box centre.
//   eval_perception [--cells goal,goal-swap,long,long-swap] [--seeds 1-10] [--json]
// Prints per entity class (the asset's kind): how often it was seen, and the centroid error's median and
// 95th percentile (3-D and horizontal); and the pipeline's time per frame (segmentation + estimation,
// one thread), p50 and p99.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "dh/campaign/plan.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/perception/colour_segmenter.hpp"
#include "dh/perception/estimate.hpp"
#include "dh/perception/rendered_frame.hpp"
#include "dh/perception/scene_entities.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/workcell_cache.hpp"

namespace {

using namespace dh;

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

struct ClassStats {
  std::size_t looked_for = 0, seen = 0;
  std::vector<double> error, horizontal;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"eval_perception: perception against simulator truth"};
  std::string cells = "goal,goal-swap,long,long-swap", seeds = "1-10";
  bool json = false;
  std::string save_dir;
  app.add_option("--cells", cells, "cells whose scenes are evaluated");
  app.add_option("--seeds", seeds, "seeds of the initial states, e.g. 1-10");
  app.add_flag("--json", json, "one JSON object on stdout");
  std::string csv_path;
  app.add_option("--csv", csv_path, "write one row per object and frame (scene, seed, entity, class, candidate masks, seen, error, sizes) to this file");
  app.add_option("--save-frames", save_dir, "write each frame's colour image as <scene>_s<seed>.png into this folder");
  CLI11_PARSE(app, argc, argv);
  try {
    cv::setNumThreads(0);  // one thread: the figure is per core
    const auto suites = load_suites(paths::config_dir());
    const auto cameras = sim::load_cameras_config(paths::config_dir() / "cameras.yaml");
    sim::GlContext gl;
    sim::check_rendering(gl, 64, 64);
    gl.make_current();
    perception::ColourSegmenter segmenter;
    perception::CloudParams cloud;
    cloud.support_z = 0;  // the workcell's table top (configs/cameras.yaml's world frame)
    std::map<std::string, ClassStats> by_class;
    std::vector<double> frame_ms;
    std::set<std::string> done;
    std::ofstream csv;
    if (!csv_path.empty()) {
      csv.open(csv_path);
      if (!csv) throw std::runtime_error("--csv " + csv_path + ": cannot write it (does its folder exist?)");
      csv << "scene,seed,entity,class,candidates,seen,confidence,error_m,horizontal_m,size_x,size_y,size_z,true_x,true_y,true_z\n";
    }
    std::size_t frames = 0;
    sim::WorkcellCache cache([&](sim::SceneSpec& s) { s.cameras = cameras.for_scene(s.name); });
    std::unique_ptr<sim::CameraRig> rig;
    for (const auto& cell_name : campaign::parse_list(cells, "--cells")) {
      const SuiteDef& suite = suites.at(cell_name);
      for (const auto& [id, task] : suite.tasks) {
        // Perception looks for what the scene names (an object cell's draws are not known to it).
        const sim::SceneSpec spec = sim::load_nominal_scene(task);
        const auto objects = perception::free_objects(spec);
        const auto appearances = perception::appearances(objects);
        for (const unsigned seed : campaign::parse_seeds(seeds)) {
          if (!done.insert(sim::task_scene_key(task, seed) + "/" + std::to_string(seed)).second) continue;
          const auto got = cache.get(task, seed);
          sim::Workcell* cell = &got.cell;
          if (got.compiled || !rig || rig->model() != cell->model()) {
            rig.reset();
            rig = std::make_unique<sim::CameraRig>(*cell, std::vector<std::string>{"workcell"}, 640, 480);
          }
          cell->reset(seed, task.goal);
          const perception::RgbdFrame frame =
              perception::rendered_frame(*rig, 0, cell->model(), cell->data());
          if (!save_dir.empty()) {
            std::filesystem::create_directories(save_dir);
            cv::Mat bgr;
            cv::cvtColor(frame.rgb, bgr, cv::COLOR_RGB2BGR);
            cv::imwrite((std::filesystem::path(save_dir) / (spec.name + "_s" + std::to_string(seed) + ".png")).string(), bgr);
          }
          segmenter.prepare(appearances);  // colour tables once per colour, outside the timing
          const auto t0 = std::chrono::steady_clock::now();
          const auto candidates = segmenter.segment(frame.rgb, appearances);
          const auto estimates = perception::estimate_objects(frame, candidates, objects, cloud);
          frame_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          ++frames;
          const Observation truth = cell->observe();
          for (const auto& a : appearances) {
            const EntityState* t = truth.entity(a.entity);
            const std::string kind = t ? t->kind : a.entity;
            auto& s = by_class[kind];
            ++s.looked_for;
            const auto e = std::find_if(estimates.begin(), estimates.end(),
                                        [&](const auto& x) { return x.entity == a.entity && x.confidence > 0; });
            const bool seen = e != estimates.end() && t;
            const Eigen::Vector3d centre =
                t ? Eigen::Vector3d(t->p[0], t->p[1], t->p[2] + t->half_extents[2]) : Eigen::Vector3d::Zero();
            const Eigen::Vector3d d = seen ? Eigen::Vector3d(e->centroid - centre) : Eigen::Vector3d::Zero();
            if (csv.is_open()) {
              const auto n = std::count_if(candidates.begin(), candidates.end(), [&](const auto& m) { return m.entity == a.entity; });
              csv << spec.name << ',' << seed << ',' << a.entity << ',' << kind << ',' << n << ',' << seen << ',';
              if (seen)  // an object not seen leaves its estimate's fields empty
                csv << e->confidence << ',' << d.norm() << ',' << d.head<2>().norm() << ',' << e->size[0] << ','
                    << e->size[1] << ',' << e->size[2];
              else
                csv << ",,,,,";
              for (int i = 0; i < 3; ++i) csv << ',' << (t ? 2 * t->half_extents[i] : 0);
              csv << '\n';
            }
            if (!seen) continue;
            ++s.seen;
            s.error.push_back(d.norm());
            s.horizontal.push_back(d.head<2>().norm());
          }
        }
      }
    }
    nlohmann::json out{{"frames", frames},
                       {"frame_ms_p50", percentile(frame_ms, 0.5)},
                       {"frame_ms_p99", percentile(frame_ms, 0.99)},
                       {"classes", nlohmann::json::array()}};
    std::vector<double> all;
    for (const auto& [kind, s] : by_class) {
      all.insert(all.end(), s.error.begin(), s.error.end());
      out["classes"].push_back({{"class", kind}, {"looked_for", s.looked_for}, {"seen", s.seen},
                                {"error_m_p50", percentile(s.error, 0.5)}, {"error_m_p95", percentile(s.error, 0.95)},
                                {"horizontal_m_p50", percentile(s.horizontal, 0.5)},
                                {"horizontal_m_p95", percentile(s.horizontal, 0.95)}});
    }
    out["error_m_p50"] = percentile(all, 0.5);
    out["error_m_p95"] = percentile(all, 0.95);
    if (json) {
      std::cout << out.dump() << "\n";
      return 0;
    }
    std::printf("%zu frames (cells %s, seeds %s), 640x480\n\n", frames, cells.c_str(), seeds.c_str());
    std::printf("| class | seen | centroid error p50 (cm) | p95 (cm) | horizontal p50 (cm) | p95 (cm) |\n|---|---|---|---|---|---|\n");
    for (const auto& c : out["classes"])
      std::printf("| %s | %zu/%zu | %.2f | %.2f | %.2f | %.2f |\n", c["class"].get<std::string>().c_str(),
                  c["seen"].get<std::size_t>(), c["looked_for"].get<std::size_t>(), 100 * c["error_m_p50"].get<double>(),
                  100 * c["error_m_p95"].get<double>(), 100 * c["horizontal_m_p50"].get<double>(),
                  100 * c["horizontal_m_p95"].get<double>());
    std::printf("| all | | %.2f | %.2f | | |\n\n", 100 * out["error_m_p50"].get<double>(), 100 * out["error_m_p95"].get<double>());
    std::printf("segmentation + estimation per frame, one thread: p50 %.1f ms, p99 %.1f ms\n",
                out["frame_ms_p50"].get<double>(), out["frame_ms_p99"].get<double>());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
