// Benchmark suites, cells and tasks, from configs/suites/*.yaml. Each suite file gives three cells: the
// unperturbed suite ("goal") and its LIBERO-Pro-style perturbations "<suite>-task" (the instruction and
// goal redirected to another object or target in the same scene) and "<suite>-swap" (task-relevant
// entities trade placements or move; instruction and goal unchanged). configs/suites/lan/wordings.yaml
// adds "<suite>-lan": each task's instruction reworded, the goal unchanged, one wording per seed;
// configs/suites/pos/positions.yaml adds "<suite>-pos": free objects placed anywhere reachable, as far
// from their places as the seed's magnitude allows; configs/suites/object/objects.yaml adds
// "<suite>-object": every free object's size, mass and shade drawn per seed, some of them another instance
// of their category.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace dh {

/// A goal predicate, e.g. On(bowl, plate).
struct PredicateSpec {
  std::string name;
  std::vector<std::string> args;
  std::string text() const;
};

/// A swap perturbation: pairs of entities exchange their placement regions (nominal xy); `moves` send an
/// entity's region to a new nominal xy.
struct SwapSpec {
  std::vector<std::array<std::string, 2>> exchange;
  std::map<std::string, std::array<double, 2>> moves;
  bool empty() const { return exchange.empty() && moves.empty(); }
  std::string text() const;  ///< stable description, e.g. "bowl<->plate;bowl->(0.1,0.2)"
};

/// A position perturbation: each free object is drawn uniformly from the disc of radius magnitude x
/// `reach_m` around its place (collision-free, reachable, clear of the table's named regions); the seed
/// picks the magnitude (seed mod the number of magnitudes), as LIBERO-Pro's x0.1...x0.5 sets.
struct PosSpec {
  std::vector<double> magnitudes;
  double reach_m = 0;
  bool empty() const { return magnitudes.empty(); }
  double magnitude_for(std::uint64_t seed) const { return magnitudes[seed % magnitudes.size()]; }
  std::string text() const;  ///< stable description, e.g. "pos 0.4 m x{0.1,0.2}"
};

/// An object perturbation, drawn per seed and free object (sim::vary_objects): another instance of its
/// category with probability `instance_share` where `instances` lists one, then its footprint and height
/// scaled by factors drawn from `width` and `height`, its mass by one from `mass`, and each colour channel
/// by 1 ± up to `shade` (the colour's name, the goal and the instruction unchanged).
struct ObjectSpec {
  std::array<double, 2> width{}, height{}, mass{};  ///< [low, high] factors
  double shade = 0;
  double instance_share = 0;
  std::map<std::string, std::vector<std::string>> instances;  ///< asset -> other assets of its category
  bool empty() const { return width[1] == 0; }
  std::string text() const;  ///< stable description, e.g. "object w[0.8,1.2] h[0.8,1.2] m[0.7,1.4] ..."
};

struct TaskDef {
  std::string suite;          ///< the cell: "goal", "goal-task", "goal-swap", ...
  std::string base_suite;     ///< "goal" or "long"
  std::string perturbation;   ///< "", "task", "swap", "lan", "pos" or "object"
  unsigned id = 0;
  std::string instruction;
  std::vector<std::string> wordings;  ///< "lan" cells: the instruction's rewordings (instruction_for)
  unsigned budget_steps = 0;
  std::filesystem::path scene_file;  ///< absolute, resolved relative to the suite file
  std::vector<PredicateSpec> goal;   ///< conjunction
  SwapSpec swap;                     ///< applied to the scene (swap cells only)
  PosSpec pos;                       ///< applied to the seed's placements (pos cells only)
  ObjectSpec object;                 ///< applied to the seed's free objects (object cells only)
};

struct SuiteDef {
  std::string name;         ///< the cell name
  std::string base_suite;
  std::string perturbation;
  std::string modelled_on;
  unsigned budget_steps = 0;
  std::map<unsigned, TaskDef> tasks;
};

/// The instruction an episode of `task` with `seed` is given: in a "lan" cell the wording the seed picks
/// (seed mod the number of wordings), elsewhere the task's instruction.
const std::string& instruction_for(const TaskDef& task, std::uint64_t seed);

/// A goal as one line: its terms joined by " AND ".
std::string goal_text(const std::vector<PredicateSpec>& goal);

/// Loads every configs/suites/*.yaml under `config_dir` (three cells per file, keyed by cell name), the
/// "lan" cells of configs/suites/lan/wordings.yaml, the "pos" cells of configs/suites/pos/positions.yaml and
/// the "object" cells of configs/suites/object/objects.yaml; throws ConfigError naming file and key.
std::map<std::string, SuiteDef> load_suites(const std::filesystem::path& config_dir);

/// The task, or ConfigError saying which suites/tasks exist.
const TaskDef& find_task(const std::map<std::string, SuiteDef>& suites, const std::string& suite,
                         unsigned task);

}  // namespace dh
