// Analytic skills for fixtures' articulated parts, each computed from the part's observed grip (handle
// bar or lever) and joint position, with the part geometry they assume as revisable parameters:
//  - slide_drawer: a closed fist, its jaw axis along the handle bar, comes in level from the front, over
//    the bar and down behind it to pull it out, or up to its front to push it in (coming down from above,
//    the Panda hand, 5 cm above the fingertips and 20 cm along its jaw, would meet the handles of the
//    drawers above; the cabinet's handles also alternate sides), then backs off;
//  - turn_knob: sweep the closed jaw across the lever's upper half (the wrist ramp) until the knob
//    reaches the on or off angle;
//  - swing_door: take the door's handle, carry it along the arc about the hinge (hinge radius and
//    handle standoff locate the hinge from the handle), let go, retreat.
#pragma once

#include "dh/cap/motion.hpp"
#include "dh/cap/skill.hpp"

namespace dh::cap {

struct DrawerParams {
  double open_position;      ///< m out at which the drawer counts open (aimed at)
  double closed_position;    ///< m: aimed at, a little past shut (the joint limit stops it)
  double done_tolerance;     ///< m from the aimed position that still completes
  double hook_offset;        ///< m from the bar's centre (behind it to open, before it to close) for the fist
  double grasp_drop;         ///< m the tool centre sits above the bar's centre
  double pull_slack;         ///< m the fist travels before it bears on the bar
  double push_slack;         ///< m the fist travels before it bears on the bar, plus a little past shut
  double bar_clearance;      ///< m between the fist and the bar's top as it comes in over the bar
  double approach_distance;  ///< m in front of the bar where the level approach starts
  double retreat_rise;       ///< m the fist rises as it backs off, clear of the drawer's walls
  double tilt;               ///< rad the fist leans about the bar, its wrist back from the fixture
  double slide_speed;        ///< m/s
  double approach_steps, descent_steps, slide_min_steps, slide_max_steps, retreat_steps;
  ParamTable table();
};

struct KnobParams {
  double on_angle;        ///< rad aimed at for on
  double off_angle;       ///< rad aimed at for off
  double on_min;          ///< rad from which the knob counts on
  double off_max;         ///< rad up to which the knob counts off
  double contact_height;  ///< m above the knob's axis where the pads' lower edge sweeps
  double lever_half_width;
  double standoff;  ///< m between pad and lever before the sweep
  double approach_height;
  double approach_steps, descent_steps, ramp_steps, retreat_steps;
  ParamTable table();
};

struct DoorParams {
  double hinge_radius;     ///< m from the hinge line to the handle, along the door
  double handle_standoff;  ///< m from the door's face to the handle
  double open_angle;       ///< rad aimed at for open
  double closed_angle;     ///< rad aimed at for closed (a little past shut: the limit stops it)
  double open_max;         ///< rad from which the door counts open
  double closed_min;       ///< rad from which the door counts closed
  double grasp_opening;
  double approach_height;  ///< m above the handle: over the door's top edge
  double approach_steps, descent_steps, close_steps, swing_steps, release_steps, retreat_steps;
  ParamTable table();
};

/// Stages shared by the three: approach above the grip, descend, close, move the part, release, retreat.
class ArticulatedSkill : public Skill {
 public:
  SkillStep next(const Observation& obs) override;

 protected:
  enum class Stage { Approach, Descent, Close, Move, Release, Retreat, Done };
  /// Called on entering Move; sets up the motion of the part.
  virtual void begin_move(const Observation& obs) = 0;
  /// The action for one step of Move; sets `finished` when the move's time is up.
  virtual std::array<double, 7> move_step(const Observation& obs, bool& finished) = 0;
  /// Whether the part reached the asked state; the failure reason when not.
  virtual std::optional<std::string> verify(const EntityState& part) const = 0;
  /// Jaw command while moving (closed on a handle, or a closed fist sweeping a lever).
  virtual double move_grip() const { return kGripClose; }
  virtual bool grasps() const { return true; }  ///< Close and Release stages run
  /// The steps the move was planned for on entering Move (its motion's, unless it keeps its own count).
  virtual int move_steps() const { return m_.steps(); }

  struct Durations {
    double approach = 30, descent = 20, close = 8, release = 8, retreat = 20;
  };
  /// Starts the approach to the tool pose (`grip_tool`, `q`) with the fingers `opening` apart, from the
  /// point `approach` away from it (straight up: from high enough to clear what stands near); the
  /// retreat goes the same way back unless `retreat` says otherwise.
  void begin(const Observation& obs, const Eigen::Vector3d& grip_tool, const Eigen::Quaterniond& q, double opening,
             const Eigen::Vector3d& approach, Durations d, int cost,
             std::optional<Eigen::Vector3d> retreat = std::nullopt);
  std::string part_;
  Stage stage_ = Stage::Done;
  Motion m_;
  Eigen::Vector3d grip_tool_{0, 0, 0};
  Eigen::Quaterniond q_{1, 0, 0, 0};
  double opening_ = 0.05;
  Eigen::Vector3d approach_{0, 0, 0.06};
  std::optional<Eigen::Vector3d> via_;  ///< a point the descent passes before the grip (over a handle)
  Eigen::Vector3d retreat_{0, 0, 0};     ///< the retreat's displacement
  Durations d_;
  int total_steps_ = 0, cost_ = 1;

 private:
  /// Counts the stage just entered at the steps it was planned for (SkillStep::planned_steps).
  void commit(int planned) { committed_ += planned; }
  /// θ's steps for the stages after the current one: the move's share is what cost_ leaves the others.
  int steps_after() const;
  int committed_ = 0;
};

class SlideDrawerSkill : public ArticulatedSkill {
 public:
  explicit SlideDrawerSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  int cost_steps() const override;

 private:
  void begin_move(const Observation& obs) override;
  std::array<double, 7> move_step(const Observation& obs, bool& finished) override;
  std::optional<std::string> verify(const EntityState& part) const override;
  bool grasps() const override { return false; }
  DrawerParams p_;
  bool open_ = true;
};

class TurnKnobSkill : public ArticulatedSkill {
 public:
  explicit TurnKnobSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  int cost_steps() const override;

 private:
  void begin_move(const Observation& obs) override;
  std::array<double, 7> move_step(const Observation& obs, bool& finished) override;
  std::optional<std::string> verify(const EntityState& part) const override;
  double move_grip() const override { return kGripClose; }
  bool grasps() const override { return false; }
  KnobParams p_;
  bool on_ = true;
  Eigen::Vector3d sweep_{0, 0, 0};  ///< direction the lever's top moves towards the asked state
  double stroke_ = 0;
};

class SwingDoorSkill : public ArticulatedSkill {
 public:
  explicit SwingDoorSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  int cost_steps() const override;

 private:
  void begin_move(const Observation& obs) override;
  std::array<double, 7> move_step(const Observation& obs, bool& finished) override;
  std::optional<std::string> verify(const EntityState& part) const override;
  DoorParams p_;
  bool open_ = false;
  Eigen::Vector2d hinge_{0, 0};
  double radius_ = 0, phi0_ = 0, sweep_ = 0, z_ = 0, yaw0_ = 0;
  int swing_step_ = 0, swing_steps_ = 1;
  int move_steps() const override { return swing_steps_; }
};

}  // namespace dh::cap
