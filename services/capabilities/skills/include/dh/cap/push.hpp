// Analytic push: the jaw, a few centimetres open and turned across the push direction, slides an object
// along the table into a target region with both finger pads. (Wide open, a round object's wall wedges
// between the fingers.) Refused before motion when the object is wider than the pads can keep on the
// push line (the paper's Figure 3: a plate), so the fast brain can substitute a pick and a place.
#pragma once

#include "dh/cap/motion.hpp"
#include "dh/cap/skill.hpp"

namespace dh::cap {

struct PushParams {
  double contact_fraction;  ///< share of the object's width the pusher must span for a stable push
  double push_opening;      ///< m between the fingers while pushing (the pads span 2.8 cm more)
  double push_height;       ///< m above the object's bottom where the pads' lower edge runs
  double standoff;          ///< m between the pads and the object before the push
  double approach_height;
  double max_speed;      ///< m/s while pushing
  double lead;           ///< m the pads aim into the object, so they keep bearing on it
  double done_distance;  ///< m from the region's centre at which the push ends
  double approach_steps, descent_steps, push_max_steps, back_off_steps, retreat_steps;

  ParamTable table();
};

class PushSkill : public Skill {
 public:
  explicit PushSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  SkillStep next(const Observation& obs) override;
  int cost_steps() const override;

 private:
  enum class Stage { Approach, Descent, Push, BackOff, Retreat, Done };
  void back_off(const Observation& obs);
  PushParams p_;
  std::string object_, target_;
  Stage stage_ = Stage::Done;
  Motion m_;
  Eigen::Vector2d dir_{1, 0};
  Eigen::Vector3d start_{0, 0, 0};
  Eigen::Quaterniond q_;
  Eigen::Vector2d object0_{0, 0};
  double travel_ = 0, reference_ = 0;
  int total_steps_ = 0, push_steps_ = 0;
};

}  // namespace dh::cap
