// The climb's plot (issue 16): the development success of each round's library with its cell × task
// cluster interval, each round marked by its decision. `dh evolve` draws it beside evolve.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dh::report {

struct ClimbPoint {
  std::string label;                   ///< "round 1", …, "final"
  double success = 0, lo = 0, hi = 0;  ///< rates in [0, 1]
  std::string decision;  ///< the round's: admitted, rejected, running; empty for the final point
};

/// Writes climb.dat and climb.gp into `dir` and runs gnuplot (its output in climb.log) to draw climb.png.
/// Returns the empty string when it was drawn, else why not (no points, no gnuplot, gnuplot failed).
std::string draw_climb(const std::vector<ClimbPoint>& points, const std::filesystem::path& dir);

}  // namespace dh::report
