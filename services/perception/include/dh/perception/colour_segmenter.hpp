// The embedded segmentation backend: colour matching in CIE Lab, per entity, from the scene
// description's material colours.
//
// Shading: a face turned from the light shows its material colour c scaled by a factor k (Lambert and
// ambient terms multiply every channel alike). So each pixel p is compared with k*c, where
// k = (p.c)/(c.c) clamped to [min_shade, max_shade], by the CIE76 distance in L*a*b*; it matches when that
// is within the tolerance. The test is evaluated once per colour for every 6-bit-per-channel bin (at the
// bin's centre, so within about 1 unit of distance of the exact pixel) and looked up per pixel. For an achromatic colour (white, grey, black: chroma below achromatic_chroma)
// brightness is the only cue, so its shade range starts at achromatic_min_shade: a white object is not
// a grey table in shadow. Achromatic entities on a background of nearly their own brightness still need
// max_area_px or another backend. A chromatic colour's range starts at the darkest shade where its chroma
// is still achromatic_chroma or more: darker, it is as grey as the achromatic ones.
// The union over an entity's colours is opened (drops speckle noise) and closed (fills specular holes and
// joins an entity's differently coloured parts); then connected components (8-connected).
//
// The candidate rule (documented in services/perception/README.md):
//  - a component is a candidate for the entity when its area is within [min_area_px, max_area_px], the entity's
//    first (main) colour covers at least `main_colour_min_fraction` of it (so a white plate is not a
//    candidate for a yellow-and-white mug, whose main colour is yellow) and at least `lit_min_fraction` of
//    it matches lit (a shading factor of `lit_min_shade` or more: not only walls in the dark);
//  - every candidate is returned as its own Mask: when several entities share a colour, or one entity is
//    split by an occluder, the caller disambiguates (by size or position); a component may be the
//    candidate of several entities;
//  - score = (share of the entity's colours present in the component, each at >= part_min_fraction)
//            x (share of the component's pixels that matched before closing);
//  - order: entities in the order asked; per entity by area, largest first (ties: topmost, then
//    leftmost pixel). Deterministic: no randomness, no threads of its own.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "dh/perception/segmenter.hpp"

namespace dh::perception {

struct ColourSegmenterParams {
  /// CIE76 distance (L* in 0..100) between the pixel and the shaded material colour.
  double tolerance = 12.0;
  /// The shading factors allowed: a highlight up to 20 % brighter than the material colour; side faces
  /// lit from above only by ambient and head light (the simulator's vertical faces: 0.15-0.32 of their
  /// colour, measured on its mugs' walls) still match, for colours that keep their chroma that dark.
  double min_shade = 0.15, max_shade = 1.2;
  double achromatic_chroma = 12.0;     ///< C*ab below this: the colour is achromatic
  double achromatic_min_shade = 0.8;   ///< the shade range of achromatic colours starts here
  int open_px = 3;   ///< opening kernel (square side, pixels); 0 = none
  int close_px = 7;  ///< closing kernel; 0 = none
  double main_colour_min_fraction = 0.2;
  double part_min_fraction = 0.02;
  /// A candidate shows some of its colour lit: at least this share of its area matches at a shading
  /// factor of lit_min_shade or more. Under the workcell's light from above an object's top is lit and its
  /// walls are not (0.15-0.32), and in the dark a chromatic colour's shades come within the tolerance of
  /// another's: a cream box's walls (38,38,31) match butter's yellow at 0.17. 0: no such test.
  double lit_min_fraction = 0.03;
  double lit_min_shade = 0.4;
};

/// Not thread-safe (it caches a lookup table per colour): one instance per thread.
class ColourSegmenter final : public Segmenter {
 public:
  static constexpr std::size_t kMaxColours = 8;  ///< per entity

  /// Throws std::invalid_argument on a non-positive tolerance or shade range.
  explicit ColourSegmenter(ColourSegmenterParams params = {});
  /// Throws std::invalid_argument on an image that is not CV_8UC3 or an entity with more than
  /// kMaxColours colours; an entity without colours gets no mask.
  std::vector<Mask> segment(const cv::Mat& rgb, const std::vector<EntityAppearance>& entities) override;
  /// Builds the lookup tables of these entities' colours now (a few ms per new colour) rather than on the
  /// first frame that needs them.
  void prepare(const std::vector<EntityAppearance>& entities);
  const ColourSegmenterParams& params() const { return params_; }

 private:
  /// Per 6-bit-per-channel colour bin: kMatch if it matches `colour`, | kLit if at a lit shade; built on
  /// first use (about 1 ms).
  const std::vector<unsigned char>& lut_of(const cv::Vec3b& colour);

  ColourSegmenterParams params_;
  std::unordered_map<std::uint32_t, std::vector<unsigned char>> luts_;
};

}  // namespace dh::perception
