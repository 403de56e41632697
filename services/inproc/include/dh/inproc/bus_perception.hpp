// Perception on the in-process bus: the perception service's core (PerceptionCore) with the settings the
// local deployments run it with — colour masks from the scene description, PCL boxes, the workcell camera
// every 10 steps, no parts camera — looking at the bus's workcell. A frame it asks for is rendered at
// once, from the cell's state at that step: over DDS the simulator renders it when the request reaches it,
// a step or so later, so an episode grounded in perception takes other steps on the bus than over DDS,
// but the same ones on every run.
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "dh/cap/host_core.hpp"
#include "dh/common/perceived_world.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/scene.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::inproc {

class BusPerception {
 public:
  /// Reads the RGB-D cameras of `config_dir`/cameras.yaml (every scene the bus perceives is compiled with
  /// them, as the simulator worker compiles its own). The OpenGL context is made at the first frame.
  explicit BusPerception(const std::filesystem::path& config_dir);
  ~BusPerception();

  /// Adds the RGB-D cameras to a scene before it is compiled (a WorkcellCache's dress).
  void dress(sim::SceneSpec& spec) const;

  /// An episode of `task` starts on `cell` (compiled with dress()); the previous one, if any, is over.
  void begin(const std::string& episode_id, const TaskDef& task, const sim::Workcell& cell,
             cap::Clock::time_point now);
  /// The episode's observation: a look when one is due, its estimate made from a frame of the cell now.
  std::vector<SceneEstimate> on_observation(const Observation& obs, cap::Clock::time_point now);
  /// Time passes with the robot still at `step`: a frame unanswered or a still robot is looked at again.
  std::vector<SceneEstimate> on_tick(cap::Clock::time_point now, std::uint32_t step);
  /// How often a still robot is looked at again: the bus's clock may not jump further while it waits.
  std::chrono::milliseconds still_every() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dh::inproc
