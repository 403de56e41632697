// The oracle a real cell lacks, for the test controller: whether a task's goal holds in the simulated
// arm's world (the benchmark's predicates, dh/sim/predicates.hpp), kept in a JSON file (goal, holds,
// time_s) that the cell's dry run sets beside the verdict perception gave.
#pragma once
#include <filesystem>
#include <string>

#include "dh/common/suite.hpp"
#include "dh/rtde/simulated_ur.hpp"
#include "dh/sim/predicates.hpp"

namespace dh::rtde {

class OracleVerdict {
 public:
  /// Throws std::invalid_argument naming a goal term the arm's world lacks.
  OracleVerdict(SimulatedUr& arm, const sim::SceneSpec& scene, const TaskDef& task, std::filesystem::path file);
  /// Judges the arm's state now (under the controller's lock); true when the verdict changed or none was
  /// judged before.
  bool judge(SimulatedUr& arm);
  bool holds() const { return holds_; }
  /// Writes the last judgement to the file, through a temporary file so a reader never sees half of it.
  void write() const;

 private:
  sim::GoalEvaluator eval_;
  std::string goal_;
  std::filesystem::path file_;
  bool judged_ = false, holds_ = false;
  double time_s_ = 0;
};

}  // namespace dh::rtde
