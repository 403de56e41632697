#include "dh/cap/vla_act.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dh::cap {

ParamTable VlaActParams::table() {
  return ParamTable("vla_act",
                    {{"execute_steps", &execute_steps},
                     {"ensemble_decay", &ensemble_decay},
                     {"cost_steps", &cost_steps},
                     {"max_wait_steps", &max_wait_steps}});
}

VlaActSkill::VlaActSkill(std::shared_ptr<ActionSource> source, const Theta& theta) : source_(std::move(source)) {
  p_.table().load(theta);
  if (!source_) throw std::invalid_argument("vla_act has no action source");
}

std::optional<std::string> VlaActSkill::check(const Bindings& args, const Observation&, int budget_steps) const {
  if (arg(args, "instruction").empty()) return std::string("vla_act needs a non-empty instruction");
  if (budget_steps < 1) return std::string("no steps of budget left");
  return std::nullopt;
}

void VlaActSkill::start(const Bindings& args, const Observation& obs, const SkillContext&) {
  instruction_ = arg(args, "instruction");
  gripper_command_ = obs.holding() ? 1 : -1;  // a hand-over does not say what the previous command did
  chunk_.clear();
  recent_.clear();
  next_ = 0;
  used_ = 0;
  waited_ = 0;
}

SkillStep VlaActSkill::next(const Observation& obs) {
  SkillStep s;
  const bool ensemble = p_.ensemble_decay > 0;
  if (ensemble || next_ >= chunk_.size() || next_ >= static_cast<std::size_t>(steps(p_.execute_steps))) {
    try {
      chunk_ = source_->chunk(obs, instruction_, gripper_command_);
      waited_ = 0;
    } catch (const SourceNotReady& e) {
      if (++waited_ > steps(p_.max_wait_steps)) {
        s.stage = "wait";
        return failed(s, FailureCode::PolicyNotReady,
                      std::string("policy not ready for ") + std::to_string(waited_) + " steps: " + e.what());
      }
      s.action[6] = gripper_command_;  // hold still, keep the jaw as it was
      s.stage = "wait";
      ++used_;
      return s;
    } catch (const std::exception& e) {
      s.stage = "infer";
      return failed(s, FailureCode::PolicyError, std::string("policy: ") + e.what());
    }
    if (chunk_.empty()) {
      s.stage = "infer";
      return failed(s, FailureCode::PolicyError, "policy returned no actions");
    }
    next_ = 0;
  }
  if (ensemble) {
    recent_.emplace_back(used_, chunk_);
    std::erase_if(recent_, [&](const auto& r) { return used_ - r.first >= static_cast<int>(r.second.size()); });
    policy::Action sum{};
    double weights = 0;
    for (const auto& [asked, c] : recent_) {
      const double w = std::exp(-p_.ensemble_decay * (used_ - asked));
      for (std::size_t d = 0; d < sum.size(); ++d) sum[d] += w * c[static_cast<std::size_t>(used_ - asked)][d];
      weights += w;
    }
    for (auto& v : sum) v /= weights;
    s.action = sum;
  } else {
    s.action = chunk_[next_++];
  }
  for (auto& v : s.action) v = std::clamp(v, -1.0, 1.0);  // a server's chunk is not trusted to be in range
  gripper_command_ = s.action[6];
  s.stage = "act";
  ++used_;
  s.progress = 1.0 - std::exp(-used_ / std::max(1.0, p_.cost_steps));
  return s;
}

int VlaActSkill::cost_steps() const { return steps(p_.cost_steps); }

CapabilityDef vla_act_def(std::shared_ptr<ActionSource> source) {
  return {"vla_act", [source](const Theta& t) -> std::unique_ptr<Skill> { return std::make_unique<VlaActSkill>(source, t); },
          source->describe(), source->longest_call()};
}

}  // namespace dh::cap
