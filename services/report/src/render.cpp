#include "dh/report/report.hpp"
#include "document.hpp"
#include "plots.hpp"

#include <fstream>
#include <stdexcept>

namespace dh::report {

namespace {

void write_or_throw(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write report file " + path.string());
}

}  // namespace

ReportFiles render(const std::vector<Source>& sources, const ReportOptions& options) {
  std::error_code ec;
  std::filesystem::create_directories(options.out_dir, ec);
  if (ec)
    throw std::runtime_error("cannot create report folder " + options.out_dir.string() + ": " + ec.message());

  const nlohmann::json summary = summarize(sources, options);
  const PlotResult plots =
      options.plots ? draw_plots(summary, sources, options.out_dir) : PlotResult{{}, true, "not requested."};
  const Document doc = build_document(summary, plots);

  ReportFiles files{options.out_dir / "report.md",
                    options.out_dir / "report.html",
                    options.out_dir / "report.json",
                    {},
                    plots.skipped,
                    plots.note};
  for (const std::string& name : plots.files) files.plots.push_back(options.out_dir / name);
  write_or_throw(files.markdown, to_markdown(doc));
  write_or_throw(files.html, to_html(doc, options.title));
  write_or_throw(files.json, summary.dump(2) + "\n");
  return files;
}

}  // namespace dh::report
