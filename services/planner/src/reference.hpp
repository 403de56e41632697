// Reference resolution: a noun phrase's description -> the scene entities it names, by their attributes
// (category, colour, where they stand, state, owner and relation), never by the words of their names;
// and the places and parts a step needs from an entity ("on the stove" -> its cook region, "open the
// microwave" -> its door).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "dh/common/observation.hpp"

namespace dh::planner {

/// What a noun phrase says about what it names.
struct Description {
  std::string said;                    ///< the phrase as said, for messages ("the red mug")
  std::string category;                ///< "mug", "drawer"; for a region noun, its owner's category if said
  std::string region;                  ///< a region noun's relation: "in" (compartment), "on" (top, burner), "front_of"
  std::vector<std::string> colours;    ///< every one must be among the entity's colour words
  std::string side;                    ///< top, bottom, middle, left, right, front, back: picks among the candidates
  int ordinal = 0;                     ///< "the second drawer": 1-based, from the top (or from the left)
  std::string state;                   ///< "open"/"closed": an articulated part's state
  std::shared_ptr<Description> owner;  ///< "of the cabinet", "the caddy's", "the knob on the stove"
  std::vector<std::string> owners;     ///< the owner already resolved (a pronoun's "its right")
  bool plural = false;                 ///< names every candidate ("both moka pots", "the mugs")
  int count = 0;                       ///< how many it says there are ("both", "the two"), 0 when unsaid
  bool indefinite = false;             ///< "a mug", "one moka pot": any one will do
  std::vector<std::string> only;       ///< candidates limited to these ("the other one", "the one you opened")
  std::vector<std::string> excluded;   ///< never these ("the other one")
  std::string unknown;                 ///< a word that names nothing in the scene ("banana")
};

/// The scene as the parser asks it.
class Scene {
 public:
  explicit Scene(const std::vector<EntityState>& entities) : entities_(entities) {}
  const std::vector<EntityState>& entities() const { return entities_; }
  const EntityState* find(const std::string& name) const;
  bool is_part(const std::string& name) const;    ///< drawer, door or knob
  bool is_region(const std::string& name) const;
  /// Regions owned by `owner` with `relation`.
  std::vector<std::string> regions(const std::string& owner, const std::string& relation) const;
  /// Parts of `owner` of a kind ("drawer", "door", "knob").
  std::vector<std::string> parts(const std::string& owner, const std::vector<std::string>& kinds) const;
  /// An articulated part is open (a drawer pulled out, a door swung) or a knob is on.
  bool articulated_away(const EntityState& part) const;

  /// The entities `d` names, in scene order; throws std::invalid_argument with a reason that quotes the
  /// phrase when none matches, or, for a singular phrase, when several do and `salient` (most recent
  /// first: what the conversation has mentioned) does not pick one.
  std::vector<std::string> resolve(const Description& d, const std::vector<std::string>& salient = {}) const;

  /// Where something put "`relation` `what`" goes: on the stove -> its "on" region, in the basket -> its
  /// "in" region (an inside that is not there: the surface, "in the rack"; else the entity, "in the
  /// bowl"), in front of the stove -> its front_of region.
  std::string place(const std::string& relation, const std::string& what, const std::string& said) const;
  /// The part to open or close (a drawer, its inside, a fixture's only door or drawer), or the knob to
  /// turn (the knob, or a fixture's only knob).
  std::string part(const std::string& what, const std::vector<std::string>& kinds, const std::string& said) const;

 private:
  const std::vector<EntityState>& entities_;
};

std::string join_names(const std::vector<std::string>& names);  ///< "a, b or c"

}  // namespace dh::planner
