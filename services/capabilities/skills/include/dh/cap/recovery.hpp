// Recovery skills the fast brain inserts after a failure, before it retries or substitutes:
//  - keyframe_return: rise clear, then return to the latest tool pose recorded earlier in the episode
//    (at a command's start, with an empty hand) that lies away from here, jaw open;
//  - release_retreat: open the jaw where the tool is, then rise straight up;
//  - regrasp and reseat (pick_place's grasp stages, dh/cap/pick_place.hpp): take the object again after a
//    missed or lost grasp (from 5 cm above), or re-seat the hand after a one-finger contact (from 1.5 cm).
#pragma once

#include "dh/cap/motion.hpp"
#include "dh/cap/skill.hpp"

namespace dh::cap {

struct KeyframeParams {
  double lift;          ///< m straight up before the return
  double min_distance;  ///< m: a keyframe nearer than this is not a return
  double lift_steps, return_steps;
  ParamTable table();
};

class KeyframeReturnSkill : public Skill {
 public:
  explicit KeyframeReturnSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  SkillStep next(const Observation& obs) override;
  int cost_steps() const override;

 private:
  KeyframeParams p_;
  Keyframe target_;
  bool lifting_ = true;
  int total_steps_ = 0;
  Motion m_;
};

struct ReleaseRetreatParams {
  double retreat_height;
  double release_steps, retreat_steps;
  ParamTable table();
};

class ReleaseRetreatSkill : public Skill {
 public:
  explicit ReleaseRetreatSkill(const Theta& theta);
  std::optional<std::string> check(const Bindings& args, const Observation& obs, int budget_steps) const override;
  void start(const Bindings& args, const Observation& obs, const SkillContext& ctx) override;
  SkillStep next(const Observation& obs) override;
  int cost_steps() const override;

 private:
  ReleaseRetreatParams p_;
  bool releasing_ = true;
  int total_steps_ = 0;
  Motion m_;
};

}  // namespace dh::cap
