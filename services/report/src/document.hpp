// The report as a list of blocks, written out once as Markdown and once as HTML so both say the same.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <variant>
#include <vector>

namespace dh::report {

struct Heading {
  int level = 1;
  std::string text;
};
struct Paragraph {
  std::string text;
};
struct Note {  ///< set apart from the text (the benchmark disclaimer)
  std::string text;
};
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};
struct Image {
  std::string file;  ///< relative to the report
  std::string alt;
};
using Block = std::variant<Heading, Paragraph, Note, Table, Image>;
using Document = std::vector<Block>;

struct PlotResult {
  std::vector<std::string> files;  ///< PNG file names in the report folder, in the order drawn
  bool skipped = false;
  std::string note;
};

/// The report's content from the summarize() object and the plots drawn.
Document build_document(const nlohmann::json& summary, const PlotResult& plots);

std::string to_markdown(const Document& doc);
std::string to_html(const Document& doc, const std::string& title);

}  // namespace dh::report
