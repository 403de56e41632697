// Comma-separated lists, as a campaign's options (`--arms full,static`) and its database's columns
// (`capabilities_missing`) write them. Private to the campaign library.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace dh::campaign {

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

/// The items between commas, each trimmed of blanks; "" is one empty item.
inline std::vector<std::string_view> split_commas(std::string_view text) {
  std::vector<std::string_view> out;
  for (std::size_t start = 0;;) {
    const std::size_t comma = text.find(',', start);
    out.push_back(trim(text.substr(start, comma - start)));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

/// The items of any range of strings, joined by commas.
template <class Range>
std::string join_commas(const Range& items) {
  std::string out;
  for (const auto& x : items) out += (out.empty() ? "" : ",") + std::string(x);
  return out;
}

}  // namespace dh::campaign
