// A slow brain that can be wrong (issue 18): errors injected into the planner's advice at declared rates,
// an option on any cell. The paper's full harness beats its static one because its VLM planner errs and
// the fast brain recovers; a perfect rules planner hides that. Profiles live in
// configs/planner_errors.yaml; the planner draws one error (or none) per plan request from the episode's
// cell, task and seed and the request's number, so a campaign is reproducible and its arms pair.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace dh {

/// What the planner got wrong in one advice (idl PlannerError: the same values in the same order).
enum class PlannerError : std::uint8_t {
  None,
  WrongCapability,  ///< another eligible capability than the step needs, same arguments
  WrongArgument,    ///< one argument replaced by another entity of the scene
  DroppedStep,      ///< the step skipped: the plan's next step advised instead
  RepeatedStep,     ///< a step already completed advised again
};
const char* to_string(PlannerError e);

/// Probability per plan request of each error; their sum is at most 1.
struct PlannerErrorRates {
  double wrong_capability = 0, wrong_argument = 0, dropped_step = 0, repeated_step = 0;
  bool none() const { return total() == 0; }
  double total() const { return wrong_capability + wrong_argument + dropped_step + repeated_step; }
  std::string text() const;  ///< "wrong_capability 0.05, wrong_argument 0.05, ..."
};

/// The seed of an episode's error draws: its cell, task and seed mixed (FNV-1a of "cell/task/seed"), so
/// tasks sharing a seed do not share their errors, while every arm on one state draws the same ones.
std::uint64_t planner_error_seed(const std::string& cell, std::uint32_t task, std::uint64_t seed);

/// The error plan request `index` of an episode with draw seed `seed` (planner_error_seed) suffers (one uniform draw against the
/// cumulative rates), and a second draw `pick` in [0, 1) that chooses among the error's candidates.
struct PlannerErrorDraw {
  PlannerError error = PlannerError::None;
  double pick = 0;
};
PlannerErrorDraw draw_planner_error(const PlannerErrorRates& rates, std::uint64_t seed, std::uint32_t index);

/// Profile `name` of `file` (configs/planner_errors.yaml); throws ConfigError naming the file, the key
/// and the profiles that exist, and a profile whose rates are negative or sum above 1.
PlannerErrorRates load_planner_errors(const std::filesystem::path& file, const std::string& name);

}  // namespace dh
