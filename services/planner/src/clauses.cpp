#include "clauses.hpp"

#include <algorithm>
#include <optional>
#include <stdexcept>

#include "lexicon.hpp"
#include "reference.hpp"

namespace dh::planner {

namespace {

using lexicon::Verb;

// What a referent is wanted for; "it" takes the most recent mention that fits.
enum class Role { object, place, openable, switchable, topic };

struct Mention {
  std::string name;
  Role role;
};

// A noun phrase as parsed, before it is resolved.
struct Phrase {
  Description d;
  enum class Pronoun { none, it, them } pronoun = Pronoun::none;
  bool one = false;       ///< "the yellow and white one": the head is a previous phrase's
  bool other = false;     ///< "the other one"
  bool has_head = false;  ///< a noun, a region noun or "one" was said
  std::string relative;   ///< "the one you opened" -> "open"
};

// A place phrase: "on top of the cabinet", "to its right", "inside" (of what was just named), "there".
struct Target {
  std::string relation;  ///< on, in, front_of, ..., or "to" ("to the front of the stove")
  Phrase what;
  bool bare = false;     ///< "inside" / "there": the place named before
};

const std::vector<std::string> kOpenable{"drawer", "door"};
const std::vector<std::string> kSwitchable{"knob"};

class Reader {
 public:
  Reader(const std::string& text, const std::vector<EntityState>& entities)
      : t_(lexicon::tokenize(text)), scene_(entities) {}

  std::vector<PlanStep> read() {
    if (t_.empty()) throw std::invalid_argument("empty instruction");
    while (i_ < t_.size()) {
      bool after = false;
      while (i_ < t_.size() && (lexicon::clause_joint(peek()) || lexicon::filler(peek()) || to_verb(i_))) {
        after = after || is("after");
        ++i_;
      }
      if (i_ >= t_.size()) break;
      groups_.emplace_back();
      clause();
      bool first = false;
      while (i_ < t_.size() && lexicon::filler(peek()) && !lexicon::verb(peek())) first = first || is("first"), ++i_;
      if (i_ < t_.size() && !boundary(i_)) throw std::invalid_argument("the rules backend does not understand '" + rest() + "'");
      // "close the microwave after putting the mug inside": the after-clause happens first.
      if (after && groups_.size() > 1) std::swap(groups_[groups_.size() - 1], groups_[groups_.size() - 2]);
      if (first) std::rotate(groups_.begin(), groups_.end() - 1, groups_.end());
    }
    return flatten();
  }

  std::vector<std::string> noun_phrase() {
    Phrase p = noun();
    if (i_ < t_.size()) throw std::invalid_argument("the rules backend does not understand '" + rest() + "'");
    return refer(p, Role::topic, {});
  }

 private:
  struct Step {
    PlanStep step;
    bool copular;  ///< "the bowl goes on the plate": the goal, with a capability chosen by default
  };

  std::vector<std::string> t_;
  std::size_t i_ = 0;
  Scene scene_;
  std::vector<Mention> mentions_;
  std::vector<std::string> group_;  ///< "them": the objects last named together
  std::vector<std::vector<Step>> groups_;
  std::vector<std::string> opened_;  ///< "the one you opened"
  // The last clause, for what a clause without a verb leaves out ("..., then the ketchup").
  std::optional<Verb> verb_;
  std::string state_, target_;

  // ---- tokens
  const std::string& peek(std::size_t k = 0) const {
    static const std::string none;
    return i_ + k < t_.size() ? t_[i_ + k] : none;
  }
  bool is(const char* w, std::size_t k = 0) const { return peek(k) == w; }
  bool to_verb(std::size_t at) const { return at + 1 < t_.size() && t_[at] == "to" && lexicon::verb(t_[at + 1]); }
  bool boundary(std::size_t at) const {
    if (at >= t_.size()) return true;
    const std::string& w = t_[at];
    return lexicon::clause_joint(w) || w == "please" || w == "too" || w == "now" || w == "first" ||
           w == "afterwards" || w == "as" || w == "for" || to_verb(at);
  }
  std::string rest() const {
    std::string s;
    for (std::size_t k = i_; k < t_.size() && !(k > i_ && t_[k] == ","); ++k) s += (s.empty() ? "" : " ") + t_[k];
    return s;
  }
  std::string said(std::size_t from) const {
    std::string s;
    for (std::size_t k = from; k < i_; ++k) s += (k > from && t_[k] != "'s" ? " " : "") + t_[k];
    return s;
  }
  bool starts_noun(std::size_t k) const {
    const std::string& w = peek(k);
    return lexicon::determiner(w) || lexicon::colour(w) || lexicon::side(w) || lexicon::ordinal(w) ||
           lexicon::number(w) || w == "both" || w == "other" || lexicon::noun(t_, i_ + k, scene_.entities());
  }

  // After a phrase and ",": a clause with its own verb, which the phrase is the topic of.
  bool topic_follows() const {
    std::size_t k = 1;
    while (i_ + k < t_.size() && lexicon::filler(peek(k)) && !lexicon::verb(peek(k))) ++k;
    return lexicon::verb(peek(k)).has_value();
  }

  // ---- noun phrases
  Phrase noun() {
    const std::size_t from = i_;
    Phrase p;
    auto pronoun = [&](Phrase::Pronoun k) {
      p.pronoun = k;
      p.d.said = said(from);
      return p;
    };
    if (is("it")) return ++i_, pronoun(Phrase::Pronoun::it);
    if (is("them")) {
      ++i_;
      if (is("both") || is("all")) ++i_;
      return pronoun(Phrase::Pronoun::them);
    }
    if (is("both") || (is("all") && is("of", 1))) {
      ++i_;
      p.d.plural = true;
      p.d.count = t_[i_ - 1] == "both" ? 2 : 0;
      if (is("of")) ++i_;
      if (is("them")) return ++i_, pronoun(Phrase::Pronoun::them);
      if (!starts_noun(0)) return pronoun(Phrase::Pronoun::them);  // "drop both into the basket"
    }
    if (lexicon::determiner(peek())) p.d.indefinite = is("a") || is("an"), ++i_;
    if (const auto n = lexicon::number(peek()); n && starts_noun(1)) {
      if (*n > 1) p.d.plural = true, p.d.count = *n;
      else p.d.indefinite = true;
      ++i_;
    }
    if (is("other")) p.other = true, ++i_;
    for (;;) {
      const std::string& w = peek();
      if (lexicon::colour(w) && !p.has_head) {
        p.d.colours.push_back(w == "gray" ? "grey" : w);
        ++i_;
        if (is("and") && lexicon::colour(peek(1))) ++i_;  // "yellow and white"
      } else if (!p.has_head && (w == "top" || w == "front" || w == "back" || w == "rear" || w == "left" || w == "right") &&
                 is("of", 1)) {
        // "the top of the cabinet", "the front of the stove": the place, named after its owner.
        p.d.region = w == "top" ? "on" : lexicon::side_relation(*lexicon::side(w));
        p.has_head = true;
        ++i_;
      } else if (w == "top" && (is("surface", 1) || is("side", 1))) {
        p.d.region = "on", p.has_head = true, i_ += 2;
      } else if (const auto s = lexicon::side(w); s && !p.has_head) {
        p.d.side = *s;
        ++i_;
        if (is("hand")) ++i_;  // "right-hand"
      } else if (const auto o = lexicon::ordinal(w); o && !p.has_head) {
        p.d.ordinal = *o, ++i_;
      } else if (!p.has_head && (w == "open" || w == "opened" || w == "closed" || w == "shut") && !boundary(i_ + 1)) {
        p.d.state = w == "open" || w == "opened" ? "open" : "closed", ++i_;
      } else if (!p.has_head && (w == "one" || w == "ones")) {
        p.one = p.has_head = true, ++i_;
      } else if ((w == "box" || w == "can" || w == "bottle" || w == "jar" || w == "carton" || w == "pack") && is("of", 1)) {
        i_ += 2;  // "the bottle of wine", "the can of alphabet soup"
      } else if (!p.has_head && w == "handle" && is("of", 1)) {
        i_ += 2;  // "the handle of the middle drawer" is how one takes the drawer
        return noun();
      } else if (!p.has_head && (w == "area" || w == "spot")) {
        p.has_head = true, ++i_;  // its relation comes after: "the area in front of the stove"
      } else if (w == "desk" || w == "little" || w == "small" || w == "big") {
        ++i_;
      } else if (const auto n = lexicon::noun(t_, i_, scene_.entities())) {
        if (p.has_head && !p.d.category.empty() && p.d.region.empty()) {
          // "the cabinet drawer": the first noun owns the second.
          auto owner = std::make_shared<Description>();
          owner->category = p.d.category;
          owner->said = "the " + p.d.category;
          p.d.owner = owner;
        }
        p.d.category = n->category;
        if (!n->region.empty()) p.d.region = n->region;
        p.d.plural = p.d.plural || n->plural;
        p.has_head = true;
        i_ += n->words;
      } else if (!p.has_head && p.d.colours.empty() && !lexicon::verb(w) && !lexicon::filler(w) && !boundary(i_) &&
                 !is("of") && !is("on") && !is("in") && !is("to") && !is("'s") && !w.empty()) {
        p.d.unknown = w, p.has_head = true, ++i_;  // "the banana": a noun this scene lacks
      } else {
        break;
      }
    }
    // Post-modifiers.
    if (is("'s")) {
      // "the caddy's back compartment": what comes before owns what follows.
      ++i_;
      auto owner = std::make_shared<Description>(p.d);
      owner->said = said(from).substr(0, said(from).size() - 2);
      Phrase owned = noun();
      owned.d.owner = owner;
      owned.d.said = said(from);
      return owned;
    }
    const bool part = std::find(kOpenable.begin(), kOpenable.end(), p.d.category) != kOpenable.end() ||
                      p.d.category == "knob";
    const bool ownable = part || p.one || !p.d.region.empty() || (p.has_head && p.d.category.empty());
    if (is("at") && lexicon::side(peek(2)) && is("of", 3)) {
      p.d.side = *lexicon::side(peek(2));  // "the compartment at the back of the caddy"
      i_ += 4;
      p.d.owner = std::make_shared<Description>(noun().d);
    } else if (ownable && (is("of") || (part && is("on") && starts_noun(1))) && p.d.region.find("_of") == std::string::npos) {
      ++i_;
      p.d.owner = std::make_shared<Description>(noun().d);  // "the top drawer of the cabinet", "the knob on the stove"
    } else if (ownable || p.d.region.find("_of") != std::string::npos) {
      if (is("of")) ++i_, p.d.owner = std::make_shared<Description>(noun().d);  // "the front of the stove"
    }
    if (p.has_head && p.d.region.empty() && p.d.category.empty() && !p.one && p.d.unknown.empty()) {
      // "the area in front of the stove"
      if (auto rel = relation_words()) {
        p.d.region = *rel;
        p.d.owner = std::make_shared<Description>(noun().d);
      }
    }
    if (is("on") && is("the", 1) && (is("left", 2) || is("right", 2)) && !lexicon::noun(t_, i_ + 3, scene_.entities()) &&
        !is("one", 3) && !is("hand", 3)) {
      p.d.side = peek(2);  // "the plate on the left"
      i_ += 3;
    }
    if ((is("you") || (is("that", 0) && is("you", 1))) && (is("opened", 1) || is("opened", 2))) {
      p.relative = "open";
      i_ += is("that") ? 3 : 2;
    }
    p.d.said = said(from);
    return p;
  }

  // "in front of", "to the right of", "behind": a relation a region has to its owner.
  std::optional<std::string> relation_words() {
    if (is("in") && is("front", 1) && is("of", 2)) return i_ += 3, std::optional<std::string>("front_of");
    if (is("in") && is("back", 1) && is("of", 2)) return i_ += 3, std::optional<std::string>("back_of");
    if (is("behind")) return ++i_, std::optional<std::string>("back_of");
    if ((is("to") || is("on")) && is("the", 1) && lexicon::side(peek(2)) && is("of", 3) && !is("top", 2)) {
      const std::string rel = lexicon::side_relation(*lexicon::side(peek(2)));
      i_ += 4;
      return rel;
    }
    return std::nullopt;
  }

  // "A, B and C", "both A and B", "the top and the bottom drawers".
  std::vector<Phrase> nouns() {
    std::vector<Phrase> list;
    const bool both = is("both") && lexicon::determiner(peek(1));
    if (both) ++i_;
    list.push_back(noun());
    while ((is("and") || is(",")) && starts_noun(1) && !lexicon::verb(peek(1)) && !is("both", 1)) {
      ++i_;
      list.push_back(noun());
    }
    if (list.size() > 1) {
      // A head said once serves every phrase of the list: "the top and the bottom drawers".
      const Phrase& last = list.back();
      for (auto& p : list) {
        if (!p.has_head && p.pronoun == Phrase::Pronoun::none) {
          p.d.category = last.d.category, p.d.region = last.d.region, p.d.owner = last.d.owner;
          p.has_head = true;
        }
        if (p.pronoun == Phrase::Pronoun::none) p.d.plural = false;
      }
    }
    if (both && list.size() != 2) throw std::invalid_argument("'both' needs two things, not " + std::to_string(list.size()));
    return list;
  }

  std::optional<Target> target() {
    const std::size_t save = i_;
    bool over = false;  // "over the post" with no relation after it
    for (; is("just") || is("up") || is("down") || is("over"); ++i_) over = is("over");
    Target t;
    if (is("there")) {
      ++i_;
      t.bare = true;
      t.relation = "there";
      return t;
    }
    if (auto rel = relation_words()) {
      t.relation = *rel;
    } else if (is("to") && is("its", 1) && lexicon::side(peek(2))) {
      // "to its right": the region on that side of what was just named.
      t.relation = lexicon::side_relation(*lexicon::side(peek(2)));
      i_ += 3;
      t.what.pronoun = Phrase::Pronoun::it;
      t.what.d.said = "it";
      return t;
    } else if (is("on") && is("top", 1) && is("of", 2)) {
      t.relation = "on", i_ += 3;
    } else if (is("on") || is("onto") || is("upon") || is("atop")) {
      t.relation = "on", ++i_;
      if (is("to")) ++i_;
    } else if (is("in") || is("into") || is("inside") || is("within")) {
      t.relation = "in", ++i_;
      if (is("of")) ++i_;
      if (boundary(i_)) return t.bare = true, t;  // "put the bowl inside"
    } else if (is("to") && !to_verb(i_)) {
      t.relation = "to", ++i_;
    } else if (over) {
      t.relation = "in";  // a ring put over a post goes into the room about its foot, the post's "in" region
    } else {
      i_ = save;
      return std::nullopt;
    }
    t.what = noun();
    return t;
  }

  // ---- reference
  std::vector<std::string> salient() const {
    std::vector<std::string> s;
    for (auto it = mentions_.rbegin(); it != mentions_.rend(); ++it) s.push_back(it->name);
    return s;
  }

  bool fits(const std::string& name, Role role) const {
    try {
      if (role == Role::openable) return scene_.part(name, kOpenable, name), true;
      if (role == Role::switchable) return scene_.part(name, kSwitchable, name), true;
    } catch (const std::invalid_argument&) {
      return false;
    }
    if (role == Role::object) return !scene_.is_region(name) && !scene_.is_part(name);
    return true;
  }

  // "it": the latest mention that can play the role, and not one of this clause's own objects ("put the
  // white mug on it"); an object is preferably something named as an object before.
  std::string it(Role role, const std::vector<std::string>& own) {
    for (int pass = 0; pass < 2; ++pass)
      for (auto m = mentions_.rbegin(); m != mentions_.rend(); ++m) {
        if (std::find(own.begin(), own.end(), m->name) != own.end() || !fits(m->name, role)) continue;
        if (pass == 0 && role == Role::object && m->role != Role::object) continue;
        return m->name;
      }
    throw std::invalid_argument("'it' refers to nothing named before that can be " +
                                std::string(role == Role::openable     ? "opened or closed"
                                            : role == Role::switchable ? "switched on or off"
                                            : role == Role::object     ? "moved"
                                                                       : "a place"));
  }

  void mention(const std::vector<std::string>& names, Role role) {
    for (const auto& n : names) mentions_.push_back({n, role});
  }

  std::vector<std::string> refer(Phrase& p, Role role, const std::vector<std::string>& own) {
    std::vector<std::string> names;
    if (p.pronoun == Phrase::Pronoun::it) {
      names = {it(role, own)};
    } else if (p.pronoun == Phrase::Pronoun::them) {
      if (group_.empty()) throw std::invalid_argument("'" + p.d.said + "' refers to nothing named before");
      if (p.d.count > 0 && group_.size() != static_cast<std::size_t>(p.d.count))
        throw std::invalid_argument("'" + p.d.said + "' refers to " + join_names(group_));
      names = group_;
    } else {
      if (p.one) anaphora(p, role);
      if (!p.has_head && p.d.unknown.empty()) throw std::invalid_argument("'" + p.d.said + "' names no thing");
      names = scene_.resolve(p.d, salient());
    }
    mention(names, role);
    return names;
  }

  // "the yellow and white one", "the front one", "the other one", "the one you opened": the head is that of
  // the latest phrase in the same role (else any), and its kin are the candidates.
  void anaphora(Phrase& p, Role role) {
    const Mention* antecedent = nullptr;
    if (p.relative == "open" && !opened_.empty()) p.d.only = opened_;
    for (int pass = 0; pass < 2 && !antecedent; ++pass)
      for (auto m = mentions_.rbegin(); m != mentions_.rend(); ++m)
        if ((pass == 1 || m->role == role) && (p.d.only.empty() || p.d.only.back() == m->name)) {
          antecedent = &*m;
          break;
        }
    if (!antecedent && !p.d.only.empty()) {
      mentions_.push_back({p.d.only.back(), role});
      antecedent = &mentions_.back();
    }
    if (!antecedent) throw std::invalid_argument("'" + p.d.said + "' refers to nothing named before");
    const EntityState* a = scene_.find(antecedent->name);
    if (a->kind == "region") {
      p.d.region = a->relation;
      p.d.owners = {a->owner};
    } else {
      p.d.category = a->category;
    }
    if (p.other)
      for (const auto& m : mentions_)
        if (m.role == antecedent->role) p.d.excluded.push_back(m.name);
  }

  std::string place(Target& t, const std::vector<std::string>& own) {
    if (t.bare) {
      if (t.relation == "there") {
        if (target_.empty()) throw std::invalid_argument("'there' refers to no place named before");
        return target_;
      }
      return scene_.place(t.relation, it(Role::place, own), "it");
    }
    if (!t.what.d.region.empty() || t.what.one) {
      const auto r = refer(t.what, Role::place, own);
      if (scene_.is_region(r.front())) return r.front();
      return scene_.place(t.relation == "to" ? "on" : t.relation, r.front(), t.what.d.said);
    }
    if (t.relation.find("_of") != std::string::npos && t.what.pronoun == Phrase::Pronoun::it) {
      return scene_.place(t.relation, it(Role::place, own), "it");
    }
    const auto r = refer(t.what, Role::place, own);
    if (r.size() != 1) throw std::invalid_argument("'" + t.what.d.said + "' is more than one place");
    return scene_.place(t.relation == "to" ? "on" : t.relation, r.front(), t.what.d.said);
  }

  // ---- steps
  void add(std::string capability, Args args, bool copular = false) {
    groups_.back().push_back({{std::move(capability), std::move(args)}, copular});
  }

  void articulate(std::vector<Phrase>& objects, const std::vector<std::string>& kinds, const std::string& state) {
    const bool knob = kinds == kSwitchable;
    for (auto& o : objects)
      for (const auto& n : refer(o, knob ? Role::switchable : Role::openable, {})) {
        const std::string part = scene_.part(n, kinds, o.d.said);
        const std::string kind = scene_.find(part)->kind;
        if (knob) add("turn_knob", {{"knob", part}, {"state", state}});
        else add(kind == "drawer" ? "slide_drawer" : "swing_door", {{kind, part}, {"state", state}});
        if (state == "open") opened_.push_back(part);
      }
    state_ = state;
  }

  void move(const std::string& capability, std::vector<Phrase>& objects, std::optional<Target>& to, bool copular = false) {
    std::vector<std::string> names;
    for (auto& o : objects)
      for (const auto& n : refer(o, Role::object, {})) names.push_back(n);
    if (std::any_of(names.begin(), names.end(), [&](const std::string& n) { return !fits(n, Role::object); }))
      throw std::invalid_argument("'" + objects.front().d.said + "' cannot be picked up and moved");
    std::string where;
    if (to) where = place(*to, names);
    else if (!target_.empty()) where = target_;
    else throw std::invalid_argument("where should '" + objects.front().d.said + "' go?");
    for (const auto& n : names) add(capability, {{"object", n}, {"target", where}}, copular);
    group_ = names;
    target_ = where;
    mention({where}, Role::place);
  }

  void clause() {
    while (lexicon::filler(peek()) && !lexicon::verb(peek())) ++i_;
    if (is("of")) {
      // "of the three cabinet drawers, open the middle one": a topic for the clause after.
      ++i_;
      Phrase p = noun();
      refer(p, Role::topic, {});
      return;
    }
    if (const auto v = lexicon::verb(peek())) return verb_clause(*v);
    if (!starts_noun(0)) throw std::invalid_argument("the rules backend does not understand '" + rest() + "'");
    std::vector<Phrase> subjects = nouns();
    if (is(",") && (is("both", 1) || is("all", 1))) {
      // "the moka pots, both of them, go on the stove"
      ++i_;
      noun();
      if (is(",")) ++i_;
    }
    std::size_t k = 0;  // "needs to go", "should go"
    while (is("should", k) || is("must", k) || is("needs", k) || is("need", k) || is("has", k) || is("have", k) || is("to", k)) ++k;
    if (lexicon::copula(peek(k))) {
      i_ += k + 1;
      auto to = target();
      if (!to) throw std::invalid_argument("where should '" + subjects.front().d.said + "' go?");
      verb_ = Verb::put;
      return move("pick_place", subjects, to, true);
    }
    if (is(",") && topic_follows()) {
      for (auto& s : subjects) refer(s, Role::topic, {});  // "the stove, switch it on"
      return;
    }
    // No verb: the last clause's verb, and its place when none is said ("..., then the ketchup").
    if (!verb_) throw std::invalid_argument("the rules backend does not understand '" + rest() + "'");
    auto to = target();
    perform(*verb_, subjects, to, state_);
  }

  void verb_clause(Verb v) {
    const std::string word = peek();
    ++i_;
    if (word == "pick" || word == "picking") {
      if (!is("up")) throw std::invalid_argument("the rules backend does not understand '" + word + " " + rest() + "'");
      ++i_;
    }
    if (v == Verb::go) {
      while (is("over") || is("to") || is("back")) ++i_;
      Phrase p = noun();
      refer(p, Role::topic, {});
      return;
    }
    std::string state = v == Verb::open ? "open" : v == Verb::close ? "closed" : "";
    auto particle = [&](bool before) {
      const auto s = lexicon::state_particle(peek());
      if (!s || (v != Verb::turn && v != Verb::push && v != Verb::pull)) return;
      if ((*s == "on" || *s == "off") != (v == Verb::turn)) return;
      if (!before && !boundary(i_ + 1)) return;
      if (before && *s == "closed" && is("in")) return;
      state = *s;
      ++i_;
    };
    particle(true);
    std::vector<Phrase> objects = nouns();
    particle(false);
    if (v == Verb::turn && state.empty()) {
      // "turn the knob on the stove to switch it on": the purpose clause says what to do.
      if (to_verb(i_)) {
        for (auto& o : objects) refer(o, Role::switchable, {});
        return;
      }
      throw std::invalid_argument("turn '" + objects.front().d.said + "' on or off?");
    }
    auto to = state.empty() ? target() : std::nullopt;
    perform(v, objects, to, state);
  }

  void perform(Verb v, std::vector<Phrase>& objects, std::optional<Target>& to, const std::string& state) {
    verb_ = v;
    if (!state.empty() && !to) return articulate(objects, v == Verb::turn ? kSwitchable : kOpenable, state);
    if (v == Verb::hold && !to) {
      std::vector<std::string> names;
      for (auto& o : objects)
        for (const auto& n : refer(o, Role::object, {})) names.push_back(n);
      group_ = names;
      return;
    }
    if (v == Verb::open || v == Verb::close || v == Verb::turn)
      throw std::invalid_argument("the rules backend does not understand '" + rest() + "'");
    move(v == Verb::push || v == Verb::pull ? "push" : "pick_place", objects, to);
  }

  // The groups in order; a step that repeats an earlier one's arguments adds nothing, but when the earlier
  // one was only stated as a goal ("the plate needs to go in front of the stove, so push it there") the
  // later verb chooses its capability.
  std::vector<PlanStep> flatten() const {
    std::vector<Step> all;
    for (const auto& g : groups_)
      for (const auto& s : g) {
        auto same = std::find_if(all.begin(), all.end(), [&](const Step& x) { return x.step.args == s.step.args; });
        if (same == all.end()) all.push_back(s);
        else if (same->copular && !s.copular) *same = s;
      }
    std::vector<PlanStep> steps;
    for (const auto& s : all) steps.push_back(s.step);
    if (steps.empty()) throw std::invalid_argument("the instruction asks for nothing to be done");
    return steps;
  }
};

}  // namespace

std::vector<PlanStep> read_instruction(const std::string& instruction, const std::vector<EntityState>& scene) {
  return Reader(instruction, scene).read();
}

std::vector<std::string> read_noun_phrase(const std::string& phrase, const std::vector<EntityState>& scene) {
  return Reader(phrase, scene).noun_phrase();
}

}  // namespace dh::planner
