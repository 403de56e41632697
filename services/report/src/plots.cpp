#include "plots.hpp"

#include <fstream>
#include <map>
#include <sstream>

#include "gnuplot.hpp"

namespace dh::report {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Every plot a report may draw; budget.png only when an episode ended with a budget, positions.png only
// when the report has -pos cells.
const std::vector<std::string> kPlotFiles{"success.png", "wall_clock.png", "budget.png", "positions.png"};

std::string success_data(const json& summary) {
  std::ostringstream out;
  out << "# cell, then per arm: rate, wilson_lo, wilson_hi (%)\n";
  for (const json& cell : summary["cells"]) {
    out << gnuplot::data_label(cell);
    for (const json& arm : summary["arms"]) {
      const json* row = nullptr;
      for (const json& s : summary["summary"])
        if (s["arm"] == arm && s["cell"] == cell) row = &s;
      if (row)
        out << ' ' << 100 * (*row)["rate"].get<double>() << ' ' << 100 * (*row)["wilson_lo"].get<double>()
            << ' ' << 100 * (*row)["wilson_hi"].get<double>();
      else
        out << " NaN NaN NaN";
    }
    out << '\n';
  }
  return out.str();
}

// One line per episode, grouped in the summary's arm × cell order so the boxes come out in that order.
std::string wall_clock_data(const json& summary, const std::vector<Source>& sources) {
  std::map<std::pair<std::string, std::string>, std::vector<double>> wall_s;
  for (const Source& source : sources)
    for (const EpisodeRecord& r : source.rows) wall_s[{r.arm, r.cell}].push_back(r.wall_s);
  std::ostringstream out;
  out << "# arm/cell, episode wall clock (s)\n";
  for (const json& s : summary["summary"]) {
    const std::string arm = s["arm"], cell = s["cell"];
    for (double w : wall_s[{arm, cell}]) out << gnuplot::data_label(arm + "/" + cell) << ' ' << w << '\n';
  }
  return out.str();
}

// The paper's fig:mech: one line per episode, the budget it had used at its end (%), by arm and outcome.
bool has_budget(const json& summary) {
  for (const json& e : summary["execution"])
    if (!e["budget_used_values"]["success"].empty() || !e["budget_used_values"]["failure"].empty()) return true;
  return false;
}

std::string budget_data(const json& summary) {
  std::ostringstream out;
  out << "# arm/outcome, budget used at the episode's end (%)\n";
  for (const json& e : summary["execution"])
    for (const char* outcome : {"success", "failure"})
      for (const json& v : e["budget_used_values"][outcome])
        out << gnuplot::data_label(e["arm"].get<std::string>() + "/" + outcome) << ' ' << 100 * v.get<double>() << '\n';
  return out.str();
}

/// A "-pos" row's line in the displacement plot: its arm and cell.
std::string series_name(const json& row) { return row["arm"].get<std::string>() + "/" + row["cell"].get<std::string>(); }

// "-pos" cells: one block per arm/cell (gnuplot's index), a line per magnitude.
std::string positions_data(const json& summary) {
  std::ostringstream out;
  out << "# per arm/cell block: radius (m), rate, wilson_lo, wilson_hi (%)\n";
  std::string last;
  for (const json& p : summary["positions"]) {
    const std::string series = series_name(p);
    if (series != last && !last.empty()) out << "\n\n";
    last = series;
    out << p["radius_m"].get<double>() << ' ' << 100 * p["rate"].get<double>() << ' '
        << 100 * p["wilson_lo"].get<double>() << ' ' << 100 * p["wilson_hi"].get<double>() << '\n';
  }
  return out.str();
}

std::vector<std::string> series_of(const json& summary) {
  std::vector<std::string> out;
  for (const json& p : summary["positions"])
    if (out.empty() || out.back() != series_name(p)) out.push_back(series_name(p));
  return out;
}

// One box per label of `data` (lines "label value"), in the order the labels come.
std::string boxes(const std::string& png, const std::string& title, const std::string& ylabel,
                  const std::string& extra, const std::string& data) {
  return "reset\nset output " + png + "\nset title " + gnuplot::quote(title) + "\nset ylabel " + gnuplot::quote(ylabel) + "\n" +
         extra +
         "set grid ytics\nunset key\nset xtics rotate by -30\nset style data boxplot\n"
         "set style fill solid 0.3 border -1\nset boxwidth 0.5\nset pointsize 0.5\nplot " +
         data + " using (1):2:(0.5):1\n";
}

std::string script(const json& summary, const fs::path& dir) {
  const auto file = [&](const char* name) { return gnuplot::quote((dir / name).string()); };
  std::ostringstream gp;
  gp << gnuplot::png_terminal(960, 540) << R"(set datafile missing 'NaN'
set output )" << file("success.png") << R"(
set title 'Success rate per arm and cell (Wilson 95 % intervals)'
set ylabel 'success (%)'
set yrange [0:105]
set grid ytics
set key outside right top
set style data histograms
set style histogram errorbars gap 2 lw 1
set style fill solid 0.6 border -1
plot )";
  const json& arms = summary["arms"];
  for (std::size_t i = 0; i < arms.size(); ++i) {
    const std::size_t col = 2 + 3 * i;
    gp << (i ? ", '' " : file("success.dat") + " ") << "using " << col << ':' << col + 1 << ':' << col + 2
       << (i ? "" : ":xtic(1)") << " title " << gnuplot::quote(arms[i]);
  }
  gp << "\n" << boxes(file("wall_clock.png"), "Episode wall clock per arm and cell", "wall clock (s)", "",
                      file("wall_clock.dat"));
  if (has_budget(summary))
    gp << boxes(file("budget.png"), "Budget used at the episode's end, by arm and outcome", "budget used (%)",
                "set yrange [0:105]\n", file("budget.dat"));
  if (const auto series = series_of(summary); !series.empty()) {
    gp << R"(reset
set output )" << file("positions.png") << R"(
set title 'Success against displacement, -pos cells (Wilson 95 % intervals)'
set xlabel 'displacement radius (m)'
set ylabel 'success (%)'
set yrange [0:105]
set grid
set key outside right top
plot )";
    for (std::size_t i = 0; i < series.size(); ++i)
      gp << (i ? ", '' " : file("positions.dat") + " ") << "index " << i
         << " using 1:2:3:4 with yerrorlines title " << gnuplot::quote(series[i]);
    gp << "\n";
  }
  gp << "set output\n";
  return gp.str();
}

}  // namespace

PlotResult draw_plots(const json& summary, const std::vector<Source>& sources, const fs::path& dir) {
  PlotResult result;
  result.skipped = true;
  for (const std::string& name : kPlotFiles) {  // an image of an earlier report must not pass for this one's
    std::error_code ec;
    fs::remove(dir / name, ec);
  }
  if (summary["summary"].empty()) {
    result.note = "no episodes to plot.";
    return result;
  }
  const fs::path program = gnuplot::find();
  if (program.empty()) {
    result.note = "gnuplot was not found on PATH (install gnuplot-nox to get the PNG plots).";
    return result;
  }
  const fs::path script_path = dir / "plots.gp";
  std::vector<std::string> expected{kPlotFiles[0], kPlotFiles[1]};
  if (has_budget(summary)) expected.push_back(kPlotFiles[2]);
  if (!summary["positions"].empty()) expected.push_back(kPlotFiles[3]);
  if (!gnuplot::write_file(dir / "success.dat", success_data(summary)) ||
      !gnuplot::write_file(dir / "positions.dat", positions_data(summary)) ||
      !gnuplot::write_file(dir / "wall_clock.dat", wall_clock_data(summary, sources)) ||
      !gnuplot::write_file(dir / "budget.dat", budget_data(summary)) ||
      !gnuplot::write_file(script_path, script(summary, dir))) {
    result.note = "could not write the plot data into " + dir.string() + ".";
    return result;
  }
  const int status = gnuplot::run(program, script_path, dir / "plots.log");
  if (status != 0) {
    result.note = (status < 0 ? std::string("gnuplot did not run")
                              : "gnuplot exited with status " + std::to_string(status)) +
                  "; see plots.log.";
    return result;
  }
  for (const std::string& name : expected) {
    std::error_code ec;
    if (fs::file_size(dir / name, ec) > 0 && !ec)
      result.files.push_back(name);
    else
      result.note += (result.note.empty() ? "gnuplot did not write " : ", ") + name;
  }
  result.skipped = result.files.size() != expected.size();
  if (result.skipped) result.note += "; see plots.log.";
  return result;
}

}  // namespace dh::report
