#include "dh/planner/rules.hpp"

#include <algorithm>
#include <cctype>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "dh/common/history.hpp"

namespace dh::planner {

namespace {

std::string normalise(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (std::isalnum(static_cast<unsigned char>(c))) out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else out += ' ';
  }
  std::istringstream in(out);
  std::string word, joined;
  while (in >> word) joined += (joined.empty() ? "" : " ") + word;
  return joined;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      if (!cur.empty()) parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) parts.push_back(cur);
  return parts;
}

const std::set<std::string> kStop{"the", "a", "an", "of", "both", "its", "to", "and", "box"};
const std::set<std::string> kSpatial{"left", "right", "front", "back"};

// Words a phrase asks for ("compartment" is what a caddy's contain region is called).
std::vector<std::string> phrase_words(const std::string& phrase) {
  std::vector<std::string> w;
  for (auto& x : split(normalise(phrase), ' '))
    if (!kStop.count(x)) w.push_back(x == "compartment" ? "contain" : x);
  return w;
}

// Words an entity's name offers: "moka_pot_1" -> moka, pot; "basket_contain_region" -> basket, contain.
std::vector<std::string> name_words(const std::string& name) {
  std::vector<std::string> w;
  for (auto& x : split(name, '_'))
    if (x != "region" && !std::all_of(x.begin(), x.end(), ::isdigit)) w.push_back(x);
  return w;
}

bool word_matches(const std::string& asked, const std::string& offered, bool& plural) {
  if (asked == offered) return true;
  if (asked == offered + "s") return plural = true;
  return false;
}

const EntityState* find(const std::vector<EntityState>& scene, const std::string& name) {
  for (const auto& e : scene)
    if (e.name == name) return &e;
  return nullptr;
}

bool is_part(const EntityState& e) { return e.kind == "drawer" || e.kind == "door" || e.kind == "knob"; }

// The articulated part of `kind` that belongs to `name` (a fixture, one of its regions, or the part itself).
std::string part_of(const std::string& name, const std::string& kind, const std::vector<EntityState>& scene) {
  const EntityState* e = find(scene, name);
  if (e && e->kind == kind) return name;
  std::vector<std::string> parts;
  const auto words = name_words(name);
  for (const auto& p : scene) {
    if (p.kind != kind) continue;
    const auto pw = name_words(p.name);
    // Same fixture (first word), and every other word of `name` in the part's name.
    if (pw.empty() || words.empty() || pw.front() != words.front()) continue;
    if (std::all_of(words.begin(), words.end(), [&](const std::string& w) {
          return std::find(pw.begin(), pw.end(), w) != pw.end();
        }))
      parts.push_back(p.name);
  }
  if (parts.empty() && !words.empty()) {
    // A region names its fixture first ("microwave_heating_region"): the fixture's only part of the kind.
    for (const auto& p : scene) {
      const auto pw = name_words(p.name);
      if (p.kind == kind && !pw.empty() && pw.front() == words.front()) parts.push_back(p.name);
    }
  }
  return parts.size() == 1 ? parts.front() : "";
}

// The inside of a container for "in/into/inside": a drawer's region, a fixture's or basket's only region.
std::string inside_of(const std::string& name, const std::vector<EntityState>& scene) {
  const EntityState* e = find(scene, name);
  if (!e || e->kind == "region") return name;
  auto words = name_words(name);
  if (is_part(*e)) words.erase(std::remove(words.begin(), words.end(), e->kind), words.end());
  std::vector<std::string> regions;
  for (const auto& r : scene) {
    if (r.kind != "region") continue;
    const auto rw = name_words(r.name);
    if (is_part(*e) ? rw == words : (!rw.empty() && rw.front() == words.front()))
      regions.push_back(r.name);
  }
  return regions.size() == 1 ? regions.front() : name;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

struct Parser {
  const std::vector<EntityState>& scene;
  std::string last_object, last_place;
  std::vector<PlanStep> steps;

  std::string one(const std::string& phrase) {
    const auto r = resolve(phrase, scene);
    if (r.empty()) throw std::invalid_argument("no single scene entity matches '" + phrase + "'");
    if (r.size() > 1) throw std::invalid_argument("'" + phrase + "' names several entities (" + join(r) + ")");
    return r.front();
  }

  std::vector<std::string> objects(const std::string& phrase) {
    if (phrase == "it") {
      if (last_object.empty()) throw std::invalid_argument("'it' refers to no object named before");
      return {last_object};
    }
    const std::string p = normalise(phrase);
    if (p.rfind("both ", 0) == 0 && p.find(" and ") != std::string::npos) {
      const auto cut = p.find(" and ");
      return {one(p.substr(5, cut - 5)), one(p.substr(cut + 5))};
    }
    auto r = resolve(p, scene);
    if (r.empty()) throw std::invalid_argument("no single scene entity matches '" + phrase + "'");
    return r;
  }

  std::string place(const std::string& phrase) {
    if (phrase == "it") {
      if (last_place.empty()) throw std::invalid_argument("'it' refers to no place named before");
      return last_place;
    }
    return one(phrase);
  }

  std::string part(const std::string& phrase, const std::vector<std::string>& kinds) {
    const std::string base = place(phrase);
    for (const auto& k : kinds)
      if (auto p = part_of(base, k, scene); !p.empty()) return p;
    throw std::invalid_argument("'" + phrase + "' has no " + join(kinds) + " to move");
  }

  void add(std::string capability, Args args) { steps.push_back({std::move(capability), std::move(args)}); }

  void clause(const std::string& c) {
    static const std::regex open_close(R"(^(open|close) (.+)$)");
    static const std::regex turn1(R"(^turn (on|off) (.+)$)"), turn2(R"(^turn (.+) (on|off)$)");
    static const std::regex push(R"(^push (.+?) (?:to|into|onto|towards|toward) (.+)$)");
    static const std::regex pick(R"(^pick up (.+)$)");
    static const std::regex inside(R"(^(?:put|place) (.+) inside$)");
    static const std::regex put(
        R"(^(?:put|place|move) (.+?) (on top of|onto|on|into|inside|in|to the (?:right|left|front|back) of) (.+)$)");
    std::smatch m;
    if (std::regex_match(c, m, open_close)) {
      const std::string p = part(m[2], {"drawer", "door"});
      const bool drawer = find(scene, p)->kind == "drawer";
      add(drawer ? "slide_drawer" : "swing_door",
          {{drawer ? "drawer" : "door", p}, {"state", m[1] == "open" ? "open" : "closed"}});
      last_place = p;
    } else if (std::regex_match(c, m, turn1) || std::regex_match(c, m, turn2)) {
      const bool state_first = m[1] == "on" || m[1] == "off";
      const std::string state = state_first ? m[1].str() : m[2].str();
      const std::string what = state_first ? m[2].str() : m[1].str();
      const std::string base = place(what);
      add("turn_knob", {{"knob", part(what, {"knob"})}, {"state", state}});
      last_place = base;
    } else if (std::regex_match(c, m, push)) {
      const std::string o = one(m[1]), t = one(m[2]);
      add("push", {{"object", o}, {"target", t}});
      last_object = o;
      last_place = t;
    } else if (std::regex_match(c, m, pick)) {
      last_object = one(m[1]);
    } else if (std::regex_match(c, m, inside)) {
      if (last_place.empty()) throw std::invalid_argument("'inside' refers to no container named before");
      for (const auto& o : objects(m[1])) add("pick_place", {{"object", o}, {"target", inside_of(last_place, scene)}});
    } else if (std::regex_match(c, m, put)) {
      const std::string prep = m[2];
      std::string target;
      if (prep.rfind("to the ", 0) == 0) {
        target = one(prep.substr(7, prep.size() - 10) + " of " + m[3].str());  // "right of the plate"
      } else {
        target = place(m[3]);
        if (prep == "in" || prep == "into" || prep == "inside") target = inside_of(target, scene);
      }
      for (const auto& o : objects(m[1])) {
        add("pick_place", {{"object", o}, {"target", target}});
        last_object = o;
      }
      last_place = target;
    } else {
      throw std::invalid_argument("the rules backend does not understand '" + c + "'");
    }
  }
};

PlannerAdvice refusal(std::string why) {
  PlannerAdvice a;
  a.refused = true;
  a.reason = std::move(why);
  return a;
}

bool eligible(const PlanContext& ctx, const std::string& cap) {
  return std::find(ctx.capabilities.begin(), ctx.capabilities.end(), cap) != ctx.capabilities.end();
}

}  // namespace

std::vector<std::string> resolve(const std::string& phrase, const std::vector<EntityState>& scene) {
  const std::vector<std::string> want = phrase_words(phrase);
  const bool both = normalise(phrase).rfind("both ", 0) == 0;
  if (want.empty()) return {};
  struct Match {
    std::string name;
    std::size_t hits, extra;
    bool plural;
  };
  std::vector<Match> matches;
  for (const auto& e : scene) {
    const auto have = name_words(e.name);
    if (have.empty()) continue;
    bool plural = false;
    std::size_t hits = 0;
    for (const auto& h : have)
      if (std::any_of(want.begin(), want.end(), [&](const std::string& w) { return word_matches(w, h, plural); })) ++hits;
    const bool phrase_in_name = std::all_of(want.begin(), want.end(), [&](const std::string& w) {
      bool p = false;
      return kSpatial.count(w) ? true : std::any_of(have.begin(), have.end(), [&](const std::string& h) { return word_matches(w, h, p); });
    });
    const bool name_in_phrase = hits == have.size();
    if (hits > 0 && (phrase_in_name || name_in_phrase)) matches.push_back({e.name, hits, have.size() - hits, plural});
  }
  if (matches.empty()) return {};
  std::sort(matches.begin(), matches.end(), [](const Match& a, const Match& b) {
    return a.hits != b.hits ? a.hits > b.hits : a.extra < b.extra;
  });
  std::vector<Match> best;
  for (const auto& m : matches)
    if (m.hits == matches.front().hits && m.extra == matches.front().extra) best.push_back(m);
  if (best.size() == 1) return {best.front().name};
  if (both || std::any_of(best.begin(), best.end(), [](const Match& m) { return m.plural; })) {
    std::vector<std::string> all;
    for (const auto& m : best) all.push_back(m.name);
    return all;
  }
  // Equal candidates told apart by where they stand, as the robot sees them (left is +y, front is -x).
  for (const auto& w : want) {
    if (!kSpatial.count(w)) continue;
    const auto key = [&](const Match& m) {
      const EntityState* e = find(scene, m.name);
      if (w == "left") return e->p[1];
      if (w == "right") return -e->p[1];
      if (w == "back") return e->p[0];
      return -e->p[0];
    };
    return {std::max_element(best.begin(), best.end(), [&](const Match& a, const Match& b) { return key(a) < key(b); })->name};
  }
  return {};
}

std::vector<PlanStep> plan_steps(const std::string& instruction, const std::vector<EntityState>& scene) {
  const std::string text = normalise(instruction);
  if (text.empty()) throw std::invalid_argument("empty instruction");
  // Clauses start with a verb after "and": "open the top drawer and put the bowl inside".
  static const std::regex verb_split(R"( and (?=(?:put|place|move|open|close|turn|push|pick)\b))");
  Parser p{scene, "", "", {}};
  for (std::sregex_token_iterator it(text.begin(), text.end(), verb_split, -1), end; it != end; ++it) p.clause(*it);
  return p.steps;
}

PlannerAdvice plan_rules(const PlanContext& ctx) {
  std::vector<PlanStep> steps;
  try {
    steps = plan_steps(ctx.instruction, ctx.scene);
  } catch (const std::invalid_argument& e) {
    return refusal(e.what());
  }
  std::vector<PlanStep> open;
  for (const auto& s : steps)
    if (!history::completed(ctx.history, s.args)) open.push_back(s);
  if (open.empty()) {
    PlannerAdvice a = refusal("every step of the plan completed");
    a.done = true;
    return a;
  }
  PlannerAdvice a;
  a.capability = open.front().capability;
  a.args = open.front().args;
  if (!eligible(ctx, a.capability)) {
    if (!eligible(ctx, "vla_act"))
      return refusal(a.capability + " is needed for step " + history::signature(a.args) +
                     " but no eligible capability provides it");
    // No analytic route: the learned policy is handed the instruction (it was trained on whole ones).
    a.rationale = a.capability + " is not eligible for step " + history::signature(a.args) +
                  ": hand the instruction to vla_act";
    a.capability = "vla_act";
    a.args = {{"instruction", ctx.instruction}};
    return a;
  }
  a.rationale = "step " + std::to_string(steps.size() - open.size() + 1) + " of " + std::to_string(steps.size()) +
                ": " + a.capability + " " + history::signature(a.args);
  a.rest.assign(open.begin() + 1, open.end());
  return a;
}

}  // namespace dh::planner
