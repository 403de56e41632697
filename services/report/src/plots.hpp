// PNG plots drawn by gnuplot: success rate per arm and cell with Wilson error bars (success.png) and the
// episode wall clock per arm and cell as box plots (wall_clock.png), the budget used at the episode's end
// by arm and outcome (budget.png), and success against displacement for "-pos" cells (positions.png).
#pragma once

#include "document.hpp"
#include "dh/report/report.hpp"

#include <filesystem>

namespace dh::report {

/// Writes the data files and plots.gp into `dir` and runs gnuplot on them (its output in plots.log).
/// Never throws for a plotting problem: a missing gnuplot, a failed run or nothing to plot is a skip with
/// the reason in the result.
PlotResult draw_plots(const nlohmann::json& summary, const std::vector<Source>& sources,
                      const std::filesystem::path& dir);

}  // namespace dh::report
