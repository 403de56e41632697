#include "dh/common/history.hpp"

#include <algorithm>

namespace dh::history {

std::string signature(Args args) {
  std::sort(args.begin(), args.end());
  std::string s = "[";
  for (const auto& [role, value] : args) s += (s.size() > 1 ? " " : "") + role + "=" + value;
  return s + "]";
}

std::string outcome_line(std::uint32_t step, const std::string& capability, const std::string& outcome,
                         const Args& args, const std::string& reason) {
  return "step " + std::to_string(step) + ": " + capability + " " + outcome + " " + signature(args) +
         (reason.empty() ? "" : ": " + reason);
}

bool completed(const std::vector<std::string>& lines, const Args& args) {
  const std::string needle = " completed " + signature(args);
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.find(needle) != std::string::npos; });
}

}  // namespace dh::history
