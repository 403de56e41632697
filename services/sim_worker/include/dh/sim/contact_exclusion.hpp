// Body pairs that can never touch, left out of collision detection (issue 18: collision filtering that
// keeps every real contact). MuJoCo 2.2 tests every geom pair of two bodies whose bounding spheres meet,
// so the drawers of one cabinet, stacked and sliding side by side, cost as many box-box tests per
// substep as an object lying on the table, and never produce a contact.
//
// A body pair is excluded when each of the two is static (welded to the world) or slides on one limited
// slide joint from a static parent, at least one of them slides, and every geom pair of theirs that the
// contact bits let collide has disjoint axis-aligned boxes over the whole joint ranges and a centimetre
// past them (the box at either end of a slide, and their hull, for a translation), widened by the geoms'
// margins and a millimetre. A body moved by a mocap is never static.
// No contact that could ever occur is dropped, so the simulation is the same bit for bit
// (test_contact_exclusion.cpp).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "dh/sim/model.hpp"

namespace dh::sim {

using BodyPair = std::pair<std::string, std::string>;

/// The pairs of `m`'s bodies that can never touch, by body name, in body order.
std::vector<BodyPair> never_touching(const mjModel_* m);

/// The same for the model the MJCF document `xml` compiles to (std::runtime_error naming `origin` when
/// MuJoCo rejects it), remembered by the document's hash for the life of the process: a probe or an
/// episode that builds a scene again compiles it once, not twice. The first time, the model compiled
/// is handed to `compiled` when one is given, for a caller that needs that same model.
std::vector<BodyPair> never_touching(const std::string& xml, const std::string& origin,
                                     ModelPtr* compiled = nullptr);

}  // namespace dh::sim
