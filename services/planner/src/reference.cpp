#include "reference.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "lexicon.hpp"

namespace dh::planner {

namespace {

std::set<std::string> words(const std::string& s) {
  std::istringstream in(s);
  std::set<std::string> w;
  for (std::string x; in >> x;)
    if (x != "and") w.insert(x);
  return w;
}

// The phrase without its determiner, as a refusal quotes what it could not find ("no 'red mug' here").
std::string bare(const std::string& said) {
  const auto space = said.find(' ');
  if (space != std::string::npos && lexicon::determiner(said.substr(0, space))) return said.substr(space + 1);
  return said;
}

bool contains(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// Which way a side counts, as the robot sees the scene: left is +y, the back is +x (away from the robot),
// the top is +z.
double toward(const EntityState& e, const std::string& side) {
  if (side == "left") return e.p[1];
  if (side == "right") return -e.p[1];
  if (side == "back") return e.p[0];
  if (side == "front") return -e.p[0];
  if (side == "top") return e.p[2];
  return -e.p[2];  // bottom
}

// Candidates in reading order for "middle" and ordinals: top to bottom when they are stacked (drawers),
// else left to right.
std::vector<const EntityState*> in_order(std::vector<const EntityState*> c) {
  const auto [lo, hi] = std::minmax_element(c.begin(), c.end(), [](auto* a, auto* b) { return a->p[2] < b->p[2]; });
  const bool stacked = (*hi)->p[2] - (*lo)->p[2] > 0.01;
  std::stable_sort(c.begin(), c.end(), [&](auto* a, auto* b) { return stacked ? a->p[2] > b->p[2] : a->p[1] > b->p[1]; });
  return c;
}

std::vector<std::string> names(const std::vector<const EntityState*>& c) {
  std::vector<std::string> n;
  for (const auto* e : c) n.push_back(e->name);
  return n;
}

}  // namespace

std::string join_names(const std::vector<std::string>& n) {
  std::string s;
  for (std::size_t i = 0; i < n.size(); ++i) s += (i == 0 ? "" : i + 1 == n.size() ? " or " : ", ") + n[i];
  return s;
}

const EntityState* Scene::find(const std::string& name) const {
  for (const auto& e : entities_)
    if (e.name == name) return &e;
  return nullptr;
}

bool Scene::is_part(const std::string& name) const {
  const EntityState* e = find(name);
  return e && (e->kind == "drawer" || e->kind == "door" || e->kind == "knob");
}

bool Scene::is_region(const std::string& name) const {
  const EntityState* e = find(name);
  return e && e->kind == "region";
}

std::vector<std::string> Scene::regions(const std::string& owner, const std::string& relation) const {
  std::vector<std::string> r;
  for (const auto& e : entities_)
    if (e.kind == "region" && e.owner == owner && e.relation == relation) r.push_back(e.name);
  return r;
}

std::vector<std::string> Scene::parts(const std::string& owner, const std::vector<std::string>& kinds) const {
  std::vector<std::string> r;
  for (const auto& e : entities_)
    if (e.owner == owner && contains(kinds, e.kind)) r.push_back(e.name);
  return r;
}

bool Scene::articulated_away(const EntityState& part) const {
  // Drawers slide in metres (0 = shut, 0.16 = out); doors and knobs turn in radians.
  return std::abs(part.joint) > (part.kind == "drawer" ? 0.05 : 0.3);
}

std::vector<std::string> Scene::resolve(const Description& d, const std::vector<std::string>& salient) const {
  if (!d.unknown.empty()) throw std::invalid_argument("no '" + d.unknown + "' in this scene");
  std::vector<std::string> owners = d.owners;
  if (d.owner) owners = resolve(*d.owner, salient);
  const bool owned = d.owner || !d.owners.empty();
  std::vector<const EntityState*> c;
  for (const auto& e : entities_) {
    if (!d.region.empty()) {
      if (e.kind != "region" || e.relation != d.region) continue;
      if (owned) {
        if (!contains(owners, e.owner)) continue;
      } else if (!d.category.empty()) {
        const EntityState* o = find(e.owner);
        if (!o || o->category != d.category) continue;
      } else if (is_part(e.owner)) {
        continue;  // a "compartment" is a fixture's, not a drawer's inside
      }
    } else {
      if (e.category.empty() || e.category != d.category) continue;
      if (owned && !contains(owners, e.owner)) continue;
    }
    const auto have = words(e.colour);
    if (!std::all_of(d.colours.begin(), d.colours.end(), [&](const std::string& w) { return have.count(w) > 0; })) continue;
    if (!d.state.empty() && (!is_part(e.name) || articulated_away(e) != (d.state == "open"))) continue;
    if (!d.only.empty() && !contains(d.only, e.name)) continue;
    if (contains(d.excluded, e.name)) continue;
    c.push_back(&e);
  }
  // "the white mug" is the all-white one when a yellow-and-white one stands beside it.
  if (!d.colours.empty() && c.size() > 1) {
    std::vector<const EntityState*> exact;
    for (const auto* e : c)
      if (words(e->colour) == std::set<std::string>(d.colours.begin(), d.colours.end())) exact.push_back(e);
    if (!exact.empty()) c = exact;
  }
  if (c.empty()) throw std::invalid_argument("no '" + bare(d.said) + "' in this scene");
  if (!d.side.empty() && c.size() > 1) {
    if (d.side == "middle") {
      if (c.size() % 2 == 0)
        throw std::invalid_argument("'" + d.said + "': no middle one among " + join_names(names(c)));
      c = {in_order(c)[c.size() / 2]};
    } else {
      c = {*std::max_element(c.begin(), c.end(), [&](auto* a, auto* b) { return toward(*a, d.side) < toward(*b, d.side); })};
    }
  }
  if (d.ordinal > 0) {
    if (static_cast<std::size_t>(d.ordinal) > c.size())
      throw std::invalid_argument("'" + d.said + "': there are only " + std::to_string(c.size()) + " (" +
                                  join_names(names(c)) + ")");
    c = {in_order(c)[d.ordinal - 1]};
  }
  if (d.plural) {
    if (d.count > 0 && c.size() != static_cast<std::size_t>(d.count))
      throw std::invalid_argument("'" + d.said + "': the scene has " + std::to_string(c.size()) + " (" +
                                  join_names(names(c)) + ")");
    return names(c);
  }
  if (c.size() == 1 || d.indefinite) return {c.front()->name};
  for (const auto& s : salient)
    if (std::any_of(c.begin(), c.end(), [&](auto* e) { return e->name == s; })) return {s};
  throw std::invalid_argument("'" + d.said + "' could be " + join_names(names(c)) + ": say which");
}

std::string Scene::place(const std::string& relation, const std::string& what, const std::string& said) const {
  const EntityState* e = find(what);
  if (relation == "on" || relation == "in") {
    if (e->kind == "region") return what;
    const auto ins = regions(what, "in"), ons = regions(what, "on");
    if (relation == "in") {
      if (ins.size() == 1) return ins.front();
      if (ins.size() > 1) throw std::invalid_argument("'" + said + "' could be " + join_names(ins) + ": say which");
      if (ons.size() == 1) return ons.front();  // "in the rack": its cradle
      return what;                              // "in the bowl"
    }
    if (ons.size() == 1) return ons.front();
    if (ons.size() > 1) throw std::invalid_argument("'" + said + "' could be " + join_names(ons) + ": say which");
    return what;
  }
  const auto r = regions(what, relation);
  if (r.size() == 1) return r.front();
  std::string words = relation.substr(0, relation.size() - 3);  // "left_of" -> "left"
  words = words == "front" ? "in front of" : words == "back" ? "behind" : "to the " + words + " of";
  if (r.empty()) throw std::invalid_argument("no place " + words + " '" + said + "' in this scene");
  throw std::invalid_argument("'" + words + " " + said + "' could be " + join_names(r) + ": say which");
}

std::string Scene::part(const std::string& what, const std::vector<std::string>& kinds, const std::string& said) const {
  const EntityState* e = find(what);
  if (contains(kinds, e->kind)) return what;
  std::string owner = what;
  if (e->kind == "region") {
    const EntityState* o = find(e->owner);
    if (o && contains(kinds, o->kind)) return o->name;  // a drawer's inside names the drawer
    owner = e->owner;
  }
  const auto p = parts(owner, kinds);
  if (p.size() == 1) return p.front();
  std::string k = kinds.front();
  for (std::size_t i = 1; i < kinds.size(); ++i) k += " or " + kinds[i];
  if (p.empty()) throw std::invalid_argument("'" + said + "' has no " + k);
  throw std::invalid_argument("'" + said + "' could be " + join_names(p) + ": say which");
}

}  // namespace dh::planner
