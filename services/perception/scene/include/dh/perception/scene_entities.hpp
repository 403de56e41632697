// What the perception service looks for in a workcell, from its scene description (the embedded
// default): the free objects and the colours of their visible parts, and the fixtures' articulated parts
// whose joint values depth tells (part_fit.hpp). Where fixtures stand and the table's regions are the
// cell's calibrated layout and are not looked for.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "dh/perception/estimate.hpp"
#include "dh/perception/part_fit.hpp"
#include "dh/perception/segmenter.hpp"
#include "dh/sim/scene.hpp"

namespace dh::perception {

/// What an object is, as its description names it (an observation's entity has the same fields).
struct ObjectIdentity {
  std::string kind;      ///< its asset's kind: "bowl"
  std::string category;  ///< what a person calls it: "cream cheese"
  std::string colour;    ///< in words; empty when the description does not say
};

/// A free object to find: its colours, and its size from its asset's geometry (the shape cue).
struct LookFor {
  EntityAppearance appearance;
  ObjectIdentity identity;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  ///< full extents of its upright box: x, y, z (m)
  /// Where it is expected (world xy, m): its nominal place in the scene description, or where the last
  /// frame saw it. Tells identical objects apart; unset, they are assigned in the scene's order.
  std::optional<Eigen::Vector2d> prior_xy;
};

/// One per free object of `scene`, in the scene's order: the entity's own colour first, then the distinct
/// colours its geoms paint themselves; mask areas from 40 px up to what its size can cover in a 640x480
/// workcell view at 0.8 m or more; the prior is its nominal place.
std::vector<LookFor> free_objects(const sim::SceneSpec& scene);
std::vector<EntityAppearance> appearances(const std::vector<LookFor>& objects);

/// One per articulated part of `scene`'s fixtures, standing where the scene puts them: its boxes (a
/// cylinder, disc or ring as its bounding box), its joint, the regions on it and its grip; the fixture's
/// own geoms and the table explain depth beside it.
std::vector<PartModel> articulated_parts(const sim::SceneSpec& scene);

/// How a candidate must look to be taken for an object.
struct ObjectMatch {
  std::size_t max_candidates = 4;  ///< the object's largest candidates that are estimated
  /// The box may differ from the object's size by at most this share of its extents' sum (summed over
  /// the three extents): a part of the robot or a fixture of the same colour is seldom the same shape.
  double max_size_mismatch = 0.5;
  double max_bottom_z_m = 0.4;  ///< objects rest on the table or a fixture: a box starting higher is not one
  /// A candidate grown over depth (estimate_objects) reaches this far beyond half the object's footprint
  /// diagonal from the candidate's centre, m.
  double grow_margin_m = 0.01;
  /// A grown candidate's box starts at most this high above the support (a plate, a stove's top): growing
  /// a robot link's lit face gives a box of some object's size in the air.
  double grown_max_bottom_m = 0.05;
  /// Of a candidate to grow, the pixels higher above the support than the object's height + this are
  /// dropped first (a robot link above it that the colour mask joined).
  double seed_margin_m = 0.05;
};

/// One estimate per object from a segmenter's candidate masks: each object's largest candidates are
/// estimated, and those whose box is near the object's size are its options, fitting it the better the
/// nearer. Candidates that are one thing (the same pixels, overlapping masks, a box over another's
/// footprint) form a blob; objects and blobs are matched one to one for the greatest sum of fits, so a
/// look-alike takes an object's blob only when that object fits elsewhere or nowhere. No blob means "not
/// seen" (confidence 0) — better than a wrong place. Identical objects (same colours and size) then trade
/// places when that lowers the sum of their distances to their priors, and one seen of two goes to the
/// one whose prior is nearer. With a known support height (params.support_z), an object not seen that way
/// tries the candidates of blobs not taken again, grown over the depth image (grow_by_depth: colour finds
/// only the lit top of a white or grey object), unless the grown box lies over an object already placed.
std::vector<EntityEstimate> estimate_objects(const RgbdFrame& frame, const std::vector<Mask>& candidates,
                                             const std::vector<LookFor>& objects, const CloudParams& params = {},
                                             const ObjectMatch& match = {});

}  // namespace dh::perception
