#include "lexicon.hpp"

#include <cctype>
#include <map>
#include <set>
#include <sstream>

namespace dh::planner::lexicon {

namespace {

const std::map<std::string, Verb> kVerbs{
    {"open", Verb::open},     {"opening", Verb::open},
    {"close", Verb::close},   {"closing", Verb::close},     {"shut", Verb::close},    {"shutting", Verb::close},
    {"turn", Verb::turn},     {"turning", Verb::turn},      {"switch", Verb::turn},   {"switching", Verb::turn},
    {"keep", Verb::turn},     {"leave", Verb::turn},
    {"put", Verb::put},       {"putting", Verb::put},       {"place", Verb::put},     {"placing", Verb::put},
    {"set", Verb::put},       {"setting", Verb::put},       {"move", Verb::put},      {"moving", Verb::put},
    {"drop", Verb::put},      {"dropping", Verb::put},      {"stick", Verb::put},     {"stack", Verb::put},
    {"stand", Verb::put},     {"rest", Verb::put},          {"lay", Verb::put},       {"bring", Verb::put},
    {"push", Verb::push},     {"pushing", Verb::push},      {"shove", Verb::push},    {"slide", Verb::push},
    {"sliding", Verb::push},  {"nudge", Verb::push},
    {"pull", Verb::pull},     {"pulling", Verb::pull},
    {"pick", Verb::hold},     {"picking", Verb::hold},      {"grab", Verb::hold},     {"take", Verb::hold},
    {"get", Verb::hold},      {"grasp", Verb::hold},        {"lift", Verb::hold},     {"find", Verb::hold},
    {"see", Verb::hold},      {"hold", Verb::hold},
    {"go", Verb::go}};

const std::map<std::string, std::string> kStates{{"open", "open"},     {"out", "open"},     {"shut", "closed"},
                                                 {"closed", "closed"}, {"close", "closed"}, {"in", "closed"},
                                                 {"on", "on"},         {"off", "off"}};

const std::set<std::string> kFillers{"please", "could", "can",  "would", "will",    "you",   "kindly", "now",
                                     "just",   "also",  "for",  "me",    "i",       "want",  "ahead",  "up",
                                     "down",   "over",  "again", "carefully", "gently", "afterwards", "too",
                                     "well",   "as",    "first"};
const std::set<std::string> kJoints{",", "and", "then", "so", "next", "finally", "after", "before"};
const std::set<std::string> kCopulas{"go", "goes", "belongs", "belong"};
const std::set<std::string> kDeterminers{"the", "a", "an", "that", "this", "these", "those"};
const std::set<std::string> kColours{"black",  "white", "red",  "yellow", "green",  "blue",  "brown",
                                     "grey",   "gray",  "silver", "orange", "pink", "purple"};
const std::map<std::string, std::string> kSides{
    {"top", "top"},       {"upper", "top"},        {"uppermost", "top"}, {"highest", "top"},
    {"bottom", "bottom"}, {"lowest", "bottom"},    {"lower", "bottom"},  {"bottommost", "bottom"},
    {"middle", "middle"}, {"centre", "middle"},    {"center", "middle"}, {"left", "left"},
    {"right", "right"},   {"front", "front"},      {"back", "back"},     {"rear", "back"}};
const std::map<std::string, int> kOrdinals{{"first", 1}, {"second", 2}, {"third", 3}, {"fourth", 4}, {"fifth", 5}};
const std::map<std::string, int> kNumbers{{"one", 1}, {"two", 2}, {"three", 3}, {"four", 4}, {"five", 5}};

// Synonyms of the asset categories (configs/assets/*.yaml). A scene's own categories need no entry.
const std::map<std::string, std::string> kSynonyms{
    {"cup", "mug"},                 {"coffee mug", "mug"},
    {"pot", "moka pot"},            {"coffee pot", "moka pot"},         {"coffee maker", "moka pot"},
    {"moka", "moka pot"},           {"espresso pot", "moka pot"},
    {"cupboard", "cabinet"},        {"cooktop", "stove"},               {"stovetop", "stove"},
    {"hob", "stove"},               {"range", "stove"},                 {"rack", "wine rack"},
    {"bottle", "wine bottle"},      {"wine", "wine bottle"},            {"soup", "alphabet soup"},
    {"sauce", "tomato sauce"},      {"cheese", "cream cheese"},         {"pudding", "chocolate pudding"},
    {"oven", "microwave"},          {"microwave oven", "microwave"},    {"dial", "knob"},
    {"tray", "plate"},              {"dish", "plate"}};

// Region nouns: the relation of the region they name, and the category that owns it when the phrase names
// no owner ("the burner" is the stove's).
struct RegionNoun {
  std::string relation, owner;
};
const std::map<std::string, RegionNoun> kRegionNouns{{"compartment", {"in", ""}},
                                                     {"slot", {"in", ""}},
                                                     {"surface", {"on", ""}},
                                                     {"burner", {"on", "stove"}},
                                                     {"cooking area", {"on", "stove"}}};

// Words for what a product comes in: "the cream cheese box", "the ketchup bottle" name the product.
const std::set<std::string> kContainers{"box", "can", "bottle", "jar", "tin", "carton", "pack", "packet", "tub", "bar"};

std::string join(const std::vector<std::string>& t, std::size_t i, std::size_t n) {
  std::string s;
  for (std::size_t k = i; k < i + n; ++k) s += (k > i ? " " : "") + t[k];
  return s;
}

std::string singular(const std::string& w) {
  if (w.size() > 3 && w.compare(w.size() - 3, 3, "ves") == 0) return w.substr(0, w.size() - 3) + "f";
  if (w.size() > 2 && w.compare(w.size() - 2, 2, "es") == 0 && kContainers.count(w.substr(0, w.size() - 2)))
    return w.substr(0, w.size() - 2);  // boxes
  if (w.size() > 1 && w.back() == 's' && w[w.size() - 2] != 's') return w.substr(0, w.size() - 1);
  return w;
}

}  // namespace

std::vector<std::string> tokenize(const std::string& text) {
  std::string spaced;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (std::isalnum(c)) spaced += static_cast<char>(std::tolower(c));
    else if (c == '\'' && i + 1 < text.size() && std::tolower(static_cast<unsigned char>(text[i + 1])) == 's' &&
             (i + 2 == text.size() || !std::isalnum(static_cast<unsigned char>(text[i + 2])))) {
      spaced += " 's ";
      ++i;
    } else if (c == ',' || c == ';' || c == '.' || c == '?' || c == '!' || c == ':') spaced += " , ";
    else spaced += ' ';
  }
  std::istringstream in(spaced);
  std::vector<std::string> tokens;
  for (std::string w; in >> w;) tokens.push_back(w);
  return tokens;
}

std::optional<Verb> verb(const std::string& word) {
  const auto it = kVerbs.find(word);
  return it == kVerbs.end() ? std::nullopt : std::optional<Verb>(it->second);
}

std::optional<std::string> state_particle(const std::string& word) {
  const auto it = kStates.find(word);
  return it == kStates.end() ? std::nullopt : std::optional<std::string>(it->second);
}

bool filler(const std::string& word) { return kFillers.count(word) > 0; }
bool clause_joint(const std::string& word) { return kJoints.count(word) > 0; }
bool copula(const std::string& word) { return kCopulas.count(word) > 0; }
bool determiner(const std::string& word) { return kDeterminers.count(word) > 0; }
bool colour(const std::string& word) { return kColours.count(word) > 0; }

std::optional<std::string> side(const std::string& word) {
  const auto it = kSides.find(word);
  return it == kSides.end() ? std::nullopt : std::optional<std::string>(it->second);
}

std::optional<int> ordinal(const std::string& word) {
  const auto it = kOrdinals.find(word);
  return it == kOrdinals.end() ? std::nullopt : std::optional<int>(it->second);
}

std::optional<int> number(const std::string& word) {
  const auto it = kNumbers.find(word);
  return it == kNumbers.end() ? std::nullopt : std::optional<int>(it->second);
}

std::string side_relation(const std::string& s) { return s + "_of"; }

std::optional<Noun> noun(const std::vector<std::string>& tokens, std::size_t i, const std::vector<EntityState>& scene) {
  std::set<std::string> categories;
  for (const auto& e : scene)
    if (!e.category.empty()) categories.insert(e.category);
  // Longest first: "wine bottle" before "bottle", "cream cheese" before "cheese".
  for (std::size_t n = std::min<std::size_t>(3, tokens.size() - i); n >= 1; --n) {
    std::string phrase = join(tokens, i, n);
    bool plural = false;
    auto known = [&](const std::string& p) {
      return categories.count(p) || kSynonyms.count(p) || kRegionNouns.count(p);
    };
    if (!known(phrase)) {
      std::vector<std::string> t(tokens.begin() + i, tokens.begin() + i + n);
      t.back() = singular(t.back());
      const std::string one = join(t, 0, n);
      if (one == phrase || !known(one)) continue;
      phrase = one;
      plural = true;
    }
    Noun out;
    out.words = n;
    out.plural = plural;
    if (const auto r = kRegionNouns.find(phrase); r != kRegionNouns.end()) {
      out.region = r->second.relation;
      out.category = r->second.owner;
      return out;
    }
    out.category = categories.count(phrase) ? phrase : kSynonyms.at(phrase);
    if (i + n < tokens.size() && kContainers.count(tokens[i + n]) && out.category != "wine bottle") ++out.words;
    return out;
  }
  return std::nullopt;
}

}  // namespace dh::planner::lexicon
