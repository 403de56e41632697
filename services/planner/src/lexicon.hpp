// The rules backend's English: the words it knows and what each means to a plan. Verbs and their
// synonyms, the particles that finish them ("pull ... open", "switch ... on"), relations, sides and
// ordinals, colours, fillers, and nouns: the scene's own categories plus a few synonyms ("cup" for a mug,
// "cupboard" for a cabinet). Nothing here names a scene entity.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh::planner::lexicon {

/// Lower-case words; ",", ";", ".", "?", "!" and ":" become "," (a clause boundary); "x's" becomes
/// "x 's"; hyphens split ("right-hand" -> right hand).
std::vector<std::string> tokenize(const std::string& text);

/// What a verb asks for. `hold` takes an object in hand (pick up, grab, find) without placing it; `go`
/// only draws attention to a place ("go over to the stove").
enum class Verb { open, close, turn, put, push, pull, hold, go };
/// "open", "shut", "switch", "placing" (gerunds too); "pick" only as "pick up".
std::optional<Verb> verb(const std::string& word);

/// A particle that sets an articulated part's state: open/out -> "open", shut/closed/in -> "closed",
/// on/off -> "on"/"off".
std::optional<std::string> state_particle(const std::string& word);

/// Words said for politeness or emphasis only ("please", "could", "you", "just", "now").
bool filler(const std::string& word);
/// Words that join clauses ("and", "then", "so", ",").
bool clause_joint(const std::string& word);
/// "goes", "go", "belongs": "the bowl goes on the plate".
bool copula(const std::string& word);

bool determiner(const std::string& word);  ///< the, a, that, this, these, those
bool colour(const std::string& word);
/// top/upper/highest -> top, bottom/lowest/lower -> bottom, middle/centre, left, right, front,
/// back/rear.
std::optional<std::string> side(const std::string& word);
/// first..fifth -> 1..5 ("second drawer").
std::optional<int> ordinal(const std::string& word);
/// one..five -> 1..5 ("the two moka pots").
std::optional<int> number(const std::string& word);
/// The region relation a side names as a place: front -> front_of, back -> back_of, left -> left_of,
/// right -> right_of.
std::string side_relation(const std::string& side);

/// A noun a scene understands: an entity category ("moka pot"), or a region noun with the relation it
/// names ("compartment" -> an "in" region, "top"/"surface" -> an "on" region, "burner" -> the stove's
/// "on" region).
struct Noun {
  std::string category;       ///< an entity category, or the owner's category of a region noun ("stove")
  std::string region;         ///< a region noun's relation ("in", "on"); empty for an entity noun
  std::size_t words = 0;      ///< tokens consumed, a trailing container word ("box", "can") included
  bool plural = false;
};

/// The longest noun at `tokens[i]` among the scene's categories and the synonyms, or none.
std::optional<Noun> noun(const std::vector<std::string>& tokens, std::size_t i, const std::vector<EntityState>& scene);

}  // namespace dh::planner::lexicon
