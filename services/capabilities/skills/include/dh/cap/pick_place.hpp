// Analytic pick-and-place from observed geometry: approach, guarded descent, close, lift, carry over a
// corridor that clears everything on the way, lower, release, retreat (about 230 steps; the paper's
// Table 8). Rims (bowls, plates, mugs) are pinched at the point nearest the tool, boxes and bottles across
// their narrow side; near the arm's base the hand leans towards it (lean_angle). The place point is the
// target's centre, or a free slot of a receptacle that holds something already, so two objects in one basket
// each get a place. Into a cavity (a region with a ceiling: a microwave) the object goes in level through the
// opening and the hand backs out the same way. Started with the object already in the jaw (after a regrasp),
// it goes on from the lift.
#pragma once

#include <array>

#include "dh/cap/motion.hpp"
#include "dh/cap/skill.hpp"

namespace dh::cap {

/// Revisable physical parameters θ (configs/library/pick_place.yaml); physical quantities only.
struct PickPlaceParams {
  double approach_height;     ///< m above the grasp point before the descent
  double corridor_height;     ///< m of the object's bottom above the table during the carry, at least
  double corridor_clearance;  ///< m above anything the carry passes over
  double rim_grasp_depth;     ///< m below a rim where the jaw closes
  double place_clearance;     ///< m between object bottom and target surface at release
  double max_speed;           ///< m/s of the tool at the fastest
  double cavity_clearance;    ///< m between object bottom and a cavity's floor at release
  double cavity_ceiling;      ///< m of a cavity's ceiling below its fixture's top (assumed thickness)
  double lean_angle;          ///< rad the tool axis leans towards the arm's base for a grasp near it
  double lean_within;         ///< m from the arm's base (horizontally) within which a grasp leans
  double retreat_height;
  double approach_steps, descent_steps, close_steps, lift_steps, carry_min_steps, carry_max_steps,
      lower_steps, release_steps, retreat_steps;

  /// `grasp_only`: the part regrasp and reseat read (the other fields stay unset and unread).
  ParamTable table(bool grasp_only);
};

/// A target region inside a fixture that stands over it and has a door (a microwave's inside): it is
/// filled level, through the fixture's front. (Open containers, a caddy or a basket, are filled from above.)
struct Cavity {
  std::string fixture;
  Eigen::Vector2d out{-1, 0};  ///< the way out through the opening
  double floor = 0, ceiling = 0, depth = 0;  ///< heights (m); region centre to the front face (m)
};
std::optional<Cavity> find_cavity(const Observation& obs, const std::string& target, const std::string& object);

class PickPlaceSkill : public Skill {
 public:
  /// `grasp_only`: the recovery skills regrasp and reseat — approach, descend and close on the object
  /// (argument `object` only), completing once it is held.
  explicit PickPlaceSkill(const Theta& theta, bool grasp_only = false);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  SkillStep next(const Observation& obs) override;
  int cost_steps() const override;
  const PickPlaceParams& params() const { return p_; }

 private:
  enum class Stage { Approach, Descent, Close, Lift, Carry, Lower, Insert, Release, Withdraw, Retreat, Done };
  void enter(Stage s, const Observation& obs);
  static const char* stage_name(Stage s);
  Eigen::Vector2d place_xy(const Observation& obs) const;
  Eigen::Vector2d entry_xy() const;  ///< in front of a cavity's opening, where the object slides in from
  double grasp_above_bottom(const EntityState& o, const robot::Gripper& g) const;
  /// Whether a grasp `from_base` (m, horizontally) from the arm's base leans, and the hand's orientation
  /// `q` leant (lean_angle, towards the base about the jaw's closing axis) when it does.
  bool leans(const Eigen::Vector2d& from_base) const;
  Eigen::Quaterniond lean(const Eigen::Quaterniond& q, const Eigen::Vector2d& from_base) const;
  double corridor_z(const Observation& obs, const Eigen::Vector2d& to) const;
  /// Fills steps_after_ for this command's plan, whose stages start() has settled.
  void plan_steps_after();

  PickPlaceParams p_;
  std::string object_, target_;
  Stage stage_ = Stage::Done;
  int total_steps_ = 0;
  int committed_ = 0;  ///< steps of the stages entered, as planned at their entry
  /// By stage: θ's steps of the stages after it in this command's plan (SkillStep::planned_steps).
  std::array<int, static_cast<int>(Stage::Done) + 1> steps_after_{};
  Motion m_;
  Eigen::Vector3d grasp_{0, 0, 0};      ///< tool position at the grasp
  Eigen::Quaterniond grasp_q_;          ///< tool orientation at the grasp
  Eigen::Vector2d grasp_offset_{0, 0};  ///< tool xy minus object xy, measured after the close
  Eigen::Vector2d place_{0, 0};         ///< object xy at the release
  double place_turn_ = 0;               ///< rad the hand turns the object about the vertical in the carry
  double grasp_height_ = 0;             ///< tool z minus object z, measured after the close
  double object_z0_ = 0;
  std::optional<Cavity> cavity_;  ///< the target is the inside of a fixture with a ceiling (a microwave)
  bool grasp_only_ = false;
  bool turned_back_ = false;  ///< the approach was tried again with the hand turned by π
  double cavity_radius_ = 0;
};

/// Whether the jaw takes this object by its rim (bowl, plate, mug) rather than across its body.
bool has_rim(const EntityState& e);
/// Radius of the rim's wall centre line.
double rim_radius(const EntityState& e);

}  // namespace dh::cap
