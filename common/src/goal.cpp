#include "dh/common/goal.hpp"

#include <stdexcept>

namespace dh {

std::string GoalTerm::text() const {
  std::string s = predicate + "(";
  for (std::size_t i = 0; i < args.size(); ++i) s += (i ? ", " : "") + args[i];
  return s + ")";
}

const char* to_string(Verifier v) { return v == Verifier::Perception ? "perception" : "oracle"; }

Verifier parse_verifier(const std::string& text) {
  if (text == "oracle") return Verifier::Oracle;
  if (text == "perception") return Verifier::Perception;
  throw std::invalid_argument("unknown verifier '" + text + "' (oracle, perception)");
}

}  // namespace dh
