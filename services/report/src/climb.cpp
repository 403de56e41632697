#include "dh/report/climb.hpp"

#include <sstream>

#include "gnuplot.hpp"

namespace dh::report {

namespace fs = std::filesystem;

std::string draw_climb(const std::vector<ClimbPoint>& points, const fs::path& dir) {
  std::error_code ec;
  fs::remove(dir / "climb.png", ec);  // an earlier climb's image must not pass for this one's
  if (points.empty()) return "no round has a success yet";
  const fs::path program = gnuplot::find();
  if (program.empty()) return "gnuplot was not found on PATH (install gnuplot-nox to get climb.png)";
  std::ostringstream data;
  data << "# index, label, success, lo, hi (%), decision\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ClimbPoint& p = points[i];
    data << i << ' ' << gnuplot::data_label(p.label) << ' ' << 100 * p.success << ' ' << 100 * p.lo << ' '
         << 100 * p.hi << ' ' << gnuplot::data_label(p.decision.empty() ? "-" : p.decision) << '\n';
  }
  const auto file = [&](const char* name) { return gnuplot::quote((dir / name).string()); };
  std::ostringstream gp;
  gp << gnuplot::png_terminal(800, 450) << "set output " << file("climb.png") << R"(
set title 'Development success of each round''s library (cell x task cluster 95 % intervals)'
set ylabel 'success (%)'
set yrange [0:105]
set offsets 0.5, 0.5, 0, 0
set grid ytics
set key outside right top
plot )"
     << file("climb.dat") << R"( using 1:3:4:5:xtic(2) with yerrorlines lw 2 pt 7 title 'success', \
     '' using 1:3:(strcol(6) eq '-' ? '' : strcol(6)) with labels offset 0,-1.5 notitle
set output
)";
  if (!gnuplot::write_file(dir / "climb.dat", data.str()) || !gnuplot::write_file(dir / "climb.gp", gp.str()))
    return "could not write the climb's plot data into " + dir.string();
  const int status = gnuplot::run(program, dir / "climb.gp", dir / "climb.log");
  if (status != 0)
    return (status < 0 ? std::string("gnuplot did not run")
                       : "gnuplot exited with status " + std::to_string(status)) +
           "; see " + (dir / "climb.log").string();
  if (fs::file_size(dir / "climb.png", ec) == 0 || ec)
    return "gnuplot did not write climb.png; see climb.log";
  return "";
}

}  // namespace dh::report
