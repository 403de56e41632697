#include "dh/planner/rules.hpp"

#include <algorithm>
#include <cctype>
#include <regex>
#include <sstream>

namespace dh::planner {

namespace {

std::string normalise(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (std::isalnum(static_cast<unsigned char>(c))) out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else if (c == '_' || std::isspace(static_cast<unsigned char>(c))) out += ' ';
  }
  std::istringstream in(out);
  std::string word, joined;
  while (in >> word) joined += (joined.empty() ? "" : " ") + word;
  return joined;
}

std::vector<std::string> words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> w;
  for (std::string x; in >> x;)
    if (x != "the" && x != "a" && x != "an") w.push_back(x);
  return w;
}

bool eligible(const PlanContext& ctx, const std::string& cap) {
  return std::find(ctx.capabilities.begin(), ctx.capabilities.end(), cap) != ctx.capabilities.end();
}

PlannerAdvice refusal(std::string why) {
  PlannerAdvice a;
  a.refused = true;
  a.reason = std::move(why);
  return a;
}

}  // namespace

std::string resolve_entity(const std::string& phrase, const std::vector<std::string>& entities) {
  const std::vector<std::string> want = words(normalise(phrase));
  if (want.empty()) return "";
  std::vector<std::string> exact, partial;
  for (const auto& e : entities) {
    const std::vector<std::string> have = words(normalise(e));
    if (have == want) exact.push_back(e);
    // Every word of the entity name appears in the phrase ("black bowl" names "bowl").
    else if (!have.empty() && std::all_of(have.begin(), have.end(), [&](const std::string& h) {
               return std::find(want.begin(), want.end(), h) != want.end();
             }))
      partial.push_back(e);
  }
  if (exact.size() == 1) return exact.front();
  if (exact.empty() && partial.size() == 1) return partial.front();
  return "";
}

PlannerAdvice plan_rules(const PlanContext& ctx) {
  const std::string text = normalise(ctx.instruction);
  if (text.empty()) return refusal("empty instruction");
  static const std::regex put(R"(^(?:put|place|move|pick up)\s+(.+?)\s+(?:and place it\s+|and put it\s+)?(?:on top of|onto|on|into|inside|in)\s+(.+)$)");
  std::smatch m;
  if (std::regex_match(text, m, put)) {
    const std::string object = resolve_entity(m[1], ctx.entities);
    const std::string target = resolve_entity(m[2], ctx.entities);
    if (object.empty()) return refusal("no single scene entity matches '" + m[1].str() + "'");
    if (target.empty()) return refusal("no single scene entity matches '" + m[2].str() + "'");
    if (!eligible(ctx, "pick_place"))
      return refusal("pick-and-place is needed but no eligible capability provides it");
    PlannerAdvice a;
    a.capability = "pick_place";
    a.args = {{"object", object}, {"target", target}};
    a.rationale = "instruction asks to move '" + object + "' onto '" + target + "'";
    return a;
  }
  return refusal("the rules backend does not understand '" + ctx.instruction + "'");
}

}  // namespace dh::planner
