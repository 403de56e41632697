// The "-object" cells' perturbation (configs/suites/object/objects.yaml): each free object of a scene gets
// its own draw per seed — another instance of its category, a scaled footprint and height, a mass and a
// shade of its colour — while its name, category, colour word and place stay.
#pragma once

#include <cstdint>

#include "dh/common/suite.hpp"
#include "dh/sim/scene.hpp"

namespace dh::sim {

/// `asset` scaled: every geom's and site's x and y (sizes and positions) by `width`, z by `height`; a ring's
/// wall thickness stays (a larger bowl has the same wall).
AssetSpec scaled(AssetSpec asset, double width, double height);

/// The scene with `seed`'s object perturbation applied to every free object (fixtures stay). Each object's
/// draws come from its own stream (the seed and its name), so adding an object to a scene changes no other.
/// Each varied entity says what was drawn in `variation` ("bowl_deep w1.08 h0.93 m1.21"). Throws ConfigError
/// naming an instance asset that does not load.
SceneSpec vary_objects(SceneSpec scene, const ObjectSpec& object, std::uint64_t seed);

}  // namespace dh::sim
