// An articulated part's joint value from depth: a drawer's travel, a door's or a knob's angle. The cell
// knows where its fixtures stand (calibration) and what their parts are made of (the description's boxes);
// a frame says how far a part has moved. For every joint value on a grid over the part's range, the part's
// boxes are placed and the frame's depth points are counted: a point on a face of the part supports that
// value, and a camera ray that passes through the part's solid before reaching its point says the part is
// not there. The best-supported value is refined on a finer grid. Points the fixture's own body or the
// table explain support nothing (a drawer's floor lies on the unit's). Pure: Eigen and OpenCV, no PCL.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "dh/perception/estimate.hpp"
#include "dh/perception/frame.hpp"

namespace dh::perception {

/// A box of a body, in that body's frame: centre, half extents, turned by `yaw` about the body's z.
struct BodyBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
  double yaw = 0;
};

/// One articulated part of a calibrated fixture.
struct PartModel {
  std::string name;  ///< as observations name it: "<fixture>_<part>" ("drawer_unit_drawer")
  std::string kind;  ///< drawer, door, knob
  Eigen::Isometry3d world_from_rest = Eigen::Isometry3d::Identity();  ///< the part's frame at joint 0
  enum class Joint { Slide, Hinge } joint = Joint::Slide;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  ///< unit, in the part's frame (the rest frame)
  double lo = 0, hi = 0;                           ///< the joint's range (m or rad)
  std::vector<BodyBox> boxes;                      ///< the part's geometry, in its frame
  /// What else explains depth near it, in the world: the fixture's body and the table (world-frame boxes).
  std::vector<BodyBox> still;
  /// Entities riding on the part, in its frame: its grip (named as the part) and its regions ("…_region").
  struct Rider {
    std::string name;
    Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  };
  std::vector<Rider> riders;

  /// The part's frame in the world at joint value `q`.
  Eigen::Isometry3d world_from_part(double q) const;
};

struct PartFitParams {
  double surface_m = 0.006;  ///< a point this near a face of the part at q (or inside it) supports q
  double slide_step_m = 0.004;     ///< coarse grid; then a quarter of it about the best value
  double hinge_step_rad = 0.03;
  /// Of the pixels whose rays may cross the part's swept volume, about this many are looked at (every n-th
  /// of every n-th row): a small knob is seen at full resolution, a drawer's front at a stride.
  std::size_t max_points = 4000;
  std::size_t min_support = 20;    ///< fewer supporting points: not seen (confidence 0)
  double through_weight = 2;       ///< a ray through the part's solid counts against q as much as this many supports
  double near_best = 0.9;          ///< values scoring this share of the best are as good (the spread)
  double margin_m = 0.03;          ///< rays are looked at where they cross the part's swept box grown by this
};

struct PartEstimate {
  std::string name;
  double joint = 0;        ///< m or rad
  double confidence = 0;   ///< 0 (not seen) .. 1
  std::size_t support = 0;  ///< points on the part's faces at `joint`
  std::size_t through = 0;  ///< rays through its solid at `joint`
  double spread = 0;        ///< the width of the joint values that score near the best (m or rad)
  Eigen::Isometry3d world_from_part = Eigen::Isometry3d::Identity();
  /// The model's riders where the fitted value puts them (world positions; their orientation is the part's).
  std::vector<std::pair<std::string, Eigen::Vector3d>> riders;
};

/// The joint value of `model` the depth points (world frame) seen from `camera` (world position) support
/// best. Confidence:
/// 0 below `min_support`; else the share of supporting points among supports and rays through, times how
/// sharply the best value stands out (1 - spread / a quarter of the range, at least 0).
PartEstimate fit_part(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& camera,
                      const PartModel& model, const PartFitParams& params = {});
/// Every part in one frame: for each, the pixels whose rays may cross its swept volume are back-projected
/// (depth in [cloud.min_depth_m, cloud.max_depth_m]) and fitted.
std::vector<PartEstimate> fit_parts(const RgbdFrame& frame, const std::vector<PartModel>& models,
                                    const PartFitParams& params = {}, const CloudParams& cloud = {});

}  // namespace dh::perception
