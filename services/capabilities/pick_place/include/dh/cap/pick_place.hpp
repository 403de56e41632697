// Analytic pick-and-place from observed geometry: approach, guarded descent, close, lift, carry over a
// corridor, lower, release, retreat (about 230 steps; the paper's Table 8). Pure logic: one call per
// observation returns the next 7-d action, so it runs the same in a process on DDS and in a test.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>

#include <Eigen/Geometry>

#include "dh/common/observation.hpp"

namespace dh::cap {

/// Revisable physical parameters θ (configs/library/pick_place.yaml); physical quantities only.
struct PickPlaceParams {
  double approach_height = 0.08;   ///< m above the grasp point before the descent
  double corridor_height = 0.16;   ///< m above the table top for the carry
  double rim_grasp_depth = 0.022;  ///< m below a rim where the jaw closes
  double place_clearance = 0.012;  ///< m between the object's bottom and the target's top at release
  double max_speed = 0.35;         ///< m/s of the tool at the fastest
  int approach_steps = 30, descent_steps = 30, close_steps = 10, lift_steps = 23;
  int carry_min_steps = 60, carry_max_steps = 80, lower_steps = 15, release_steps = 10,
      retreat_steps = 23;
  double retreat_height = 0.1;

  /// Parameters from a name→value map; unknown names throw std::invalid_argument naming them.
  static PickPlaceParams from_map(const std::map<std::string, double>& theta);
  std::map<std::string, double> to_map() const;
  /// Cost model: the steps one nominal execution needs.
  int cost_steps() const;
};

enum class SkillStatus { Running, Completed, Failed };

struct SkillStep {
  SkillStatus status = SkillStatus::Running;
  std::array<double, 7> action{};
  std::string stage;
  std::string reason;
  double progress = 0;
};

class PickPlaceSkill {
 public:
  explicit PickPlaceSkill(PickPlaceParams params) : p_(params) {}

  /// Grounding at the capability, before any motion: entities present, graspable, distinct, and the
  /// budget pays for the cost model. Returns the refusal reason, or nullopt when it can start.
  std::optional<std::string> check(const std::string& object, const std::string& target,
                                   const Observation& obs, int budget_steps) const;
  /// Plans the grasp from the observation; call check() first.
  void start(const std::string& object, const std::string& target, const Observation& obs);
  /// The action for this observation (the status says when the command ended).
  SkillStep next(const Observation& obs);

 private:
  enum class Stage { Approach, Descent, Close, Lift, Carry, Lower, Release, Retreat, Done };
  struct Segment {
    Eigen::Vector3d from, to;
    Eigen::Quaterniond q_from, q_to;
    int steps = 1;
  };
  void enter(Stage s, const Observation& obs);
  SkillStep act(const Observation& obs, const Eigen::Vector3d& p, const Eigen::Quaterniond& q, double grip);
  static const char* stage_name(Stage s);

  PickPlaceParams p_;
  std::string object_, target_;
  Stage stage_ = Stage::Done;
  int stage_step_ = 0, total_steps_ = 0;
  Segment seg_;
  Eigen::Vector3d grasp_{0, 0, 0};      ///< tool position at the grasp
  Eigen::Quaterniond grasp_q_;          ///< tool orientation at the grasp
  Eigen::Vector2d grasp_offset_{0, 0};  ///< tool xy minus object xy, measured after the close
  double grasp_height_ = 0;             ///< tool z minus object z, measured after the close
  double object_z0_ = 0;
};

}  // namespace dh::cap
