#include "document.hpp"

namespace dh::report {

namespace {

template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
  return s;
}

std::string md_cell(const std::string& s) { return replace_all(s, "|", "\\|"); }

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string md_row(const std::vector<std::string>& cells) {
  std::string line = "|";
  for (const std::string& c : cells) line += " " + md_cell(c) + " |";
  return line + "\n";
}

constexpr const char* kStyle =
    "body{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0 1.5em}"
    "th,td{border:1px solid #bbb;padding:0.25em 0.6em;text-align:right}"
    "th{background:#eee}td:first-child,th:first-child{text-align:left}"
    ".note{border-left:4px solid #c60;background:#fff4e5;padding:0.5em 1em}"
    "img{max-width:100%}";

}  // namespace

std::string to_markdown(const Document& doc) {
  std::string out;
  for (const Block& block : doc) {
    std::visit(Overloaded{
                   [&](const Heading& h) { out += std::string(h.level, '#') + " " + h.text + "\n\n"; },
                   [&](const Paragraph& p) { out += p.text + "\n\n"; },
                   [&](const Note& n) { out += "> " + n.text + "\n\n"; },
                   [&](const Table& t) {
                     out += md_row(t.header);
                     out += md_row(std::vector<std::string>(t.header.size(), "---"));
                     for (const auto& row : t.rows) out += md_row(row);
                     out += "\n";
                   },
                   [&](const Image& i) { out += "![" + i.alt + "](" + i.file + ")\n\n"; },
               },
               block);
  }
  return out;
}

std::string to_html(const Document& doc, const std::string& title) {
  std::string out = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
                    html_escape(title) + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n";
  for (const Block& block : doc) {
    std::visit(Overloaded{
                   [&](const Heading& h) {
                     const std::string tag = "h" + std::to_string(h.level);
                     out += "<" + tag + ">" + html_escape(h.text) + "</" + tag + ">\n";
                   },
                   [&](const Paragraph& p) { out += "<p>" + html_escape(p.text) + "</p>\n"; },
                   [&](const Note& n) { out += "<p class=\"note\">" + html_escape(n.text) + "</p>\n"; },
                   [&](const Table& t) {
                     out += "<table>\n<tr>";
                     for (const auto& h : t.header) out += "<th>" + html_escape(h) + "</th>";
                     out += "</tr>\n";
                     for (const auto& row : t.rows) {
                       out += "<tr>";
                       for (const auto& c : row) out += "<td>" + html_escape(c) + "</td>";
                       out += "</tr>\n";
                     }
                     out += "</table>\n";
                   },
                   [&](const Image& i) {
                     out += "<p><img src=\"" + html_escape(i.file) + "\" alt=\"" + html_escape(i.alt) +
                            "\"></p>\n";
                   },
               },
               block);
  }
  return out + "</body>\n</html>\n";
}

}  // namespace dh::report
