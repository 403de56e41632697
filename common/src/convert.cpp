#include "dh/common/convert.hpp"

#include "dh/common/command.hpp"
#include "dh/common/seam_event.hpp"
#include "dh/msg/command.h"
#include "dh/msg/episode.h"
#include "dh/msg/robot.h"

#include <algorithm>

namespace dh::convert {

std::vector<EntityState> from_msg(const std::vector<msg::EntityPose>& entities) {
  std::vector<EntityState> out;
  for (const auto& e : entities) {
    EntityState s;
    s.name = e.name();
    s.kind = e.kind();
    std::copy_n(e.pose().p().begin(), 3, s.p.begin());
    std::copy_n(e.pose().q().begin(), 4, s.q.begin());
    std::copy_n(e.half_extents().begin(), 3, s.half_extents.begin());
    s.joint = e.joint();
    s.category = e.category();
    s.colour = e.colour();
    s.owner = e.owner();
    s.relation = e.relation();
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<msg::EntityPose> to_msg(const std::vector<EntityState>& entities) {
  std::vector<msg::EntityPose> out;
  for (const auto& e : entities) {
    msg::EntityPose p;
    p.name(e.name);
    p.kind(e.kind);
    std::copy_n(e.p.begin(), 3, p.pose().p().begin());
    std::copy_n(e.q.begin(), 4, p.pose().q().begin());
    std::copy_n(e.half_extents.begin(), 3, p.half_extents().begin());
    p.joint(e.joint);
    p.category(e.category);
    p.colour(e.colour);
    p.owner(e.owner);
    p.relation(e.relation);
    out.push_back(std::move(p));
  }
  return out;
}

Observation from_msg(const msg::Observation& m) {
  Observation o;
  o.channel = m.channel();
  o.step = m.step();
  o.budget_steps = m.budget_steps();
  std::copy_n(m.ee().p().begin(), 3, o.ee_p.begin());
  std::copy_n(m.ee().q().begin(), 4, o.ee_q.begin());
  o.gripper_opening = m.gripper_opening();
  o.contact_left = m.contact_left();
  o.contact_right = m.contact_right();
  o.gripper = {m.gripper().pad_below_tcp(), m.gripper().pad_half_width(), m.gripper().pad_thickness(),
               m.gripper().hand_above_tcp()};
  std::copy_n(m.base_p().begin(), 3, o.base_p.begin());
  std::copy_n(m.q().begin(), 7, o.q.begin());
  std::copy_n(m.dq().begin(), 7, o.dq.begin());
  o.entities = from_msg(m.entities());
  o.goal_holds = m.task_predicate();
  o.episode_id = m.episode_id();
  return o;
}

msg::Observation to_msg(const Observation& o, std::uint32_t channel, const std::string& episode_id) {
  msg::Observation m;
  m.channel(channel);
  m.episode_id(episode_id);
  m.step(o.step);
  m.budget_steps(o.budget_steps);
  std::copy_n(o.ee_p.begin(), 3, m.ee().p().begin());
  std::copy_n(o.ee_q.begin(), 4, m.ee().q().begin());
  m.gripper_opening(o.gripper_opening);
  m.contact_left(o.contact_left);
  m.contact_right(o.contact_right);
  m.gripper().pad_below_tcp(o.gripper.pad_below_tcp);
  m.gripper().pad_half_width(o.gripper.pad_half_width);
  m.gripper().pad_thickness(o.gripper.pad_thickness);
  m.gripper().hand_above_tcp(o.gripper.hand_above_tcp);
  std::copy_n(o.base_p.begin(), 3, m.base_p().begin());
  std::copy_n(o.q.begin(), 7, m.q().begin());
  std::copy_n(o.dq.begin(), 7, m.dq().begin());
  m.entities(to_msg(o.entities));
  m.task_predicate(o.goal_holds);
  return m;
}

std::vector<std::pair<std::string, std::string>> from_msg(const std::vector<msg::Binding>& b) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& x : b) out.emplace_back(x.role(), x.entity());
  return out;
}

std::vector<msg::Binding> to_msg(const std::vector<std::pair<std::string, std::string>>& b) {
  std::vector<msg::Binding> out;
  for (const auto& [role, entity] : b) {
    msg::Binding x;
    x.role(role);
    x.entity(entity);
    out.push_back(std::move(x));
  }
  return out;
}

Outcome from_msg(msg::Outcome o) {
  const auto v = static_cast<int>(o);
  return v >= 0 && v <= static_cast<int>(Outcome::Rejected) ? static_cast<Outcome>(v) : Outcome::Infrastructure;
}

PerceptionLimits from_msg(const msg::PerceptionLimits& m) {
  return {m.max_age_steps(), m.min_confidence(), std::chrono::milliseconds(m.wait_ms())};
}

msg::PerceptionLimits to_msg(const PerceptionLimits& l) {
  msg::PerceptionLimits m;
  m.max_age_steps(l.max_age_steps);
  m.min_confidence(l.min_confidence);
  m.wait_ms(static_cast<std::uint32_t>(l.wait.count()));
  return m;
}

PlannerErrorRates from_msg(const msg::PlannerErrorRates& m) {
  return {m.wrong_capability(), m.wrong_argument(), m.dropped_step(), m.repeated_step()};
}

msg::PlannerErrorRates to_msg(const PlannerErrorRates& r) {
  msg::PlannerErrorRates m;
  m.wrong_capability(r.wrong_capability);
  m.wrong_argument(r.wrong_argument);
  m.dropped_step(r.dropped_step);
  m.repeated_step(r.repeated_step);
  return m;
}

std::vector<GoalTerm> from_msg(const std::vector<msg::GoalTerm>& m) {
  std::vector<GoalTerm> out;
  out.reserve(m.size());
  for (const auto& t : m) out.push_back({t.predicate(), t.args(), t.part(), t.lo(), t.hi()});
  return out;
}

std::vector<msg::GoalTerm> to_msg(const std::vector<GoalTerm>& goal) {
  std::vector<msg::GoalTerm> out;
  out.reserve(goal.size());
  for (const auto& t : goal) {
    msg::GoalTerm m;
    m.predicate(t.predicate);
    m.args(t.args);
    m.part(t.part);
    m.lo(t.lo);
    m.hi(t.hi);
    out.push_back(std::move(m));
  }
  return out;
}

std::optional<Verifier> from_msg(msg::Verifier v) {
  switch (v) {
    case msg::VERIFIER_ORACLE: return Verifier::Oracle;
    case msg::VERIFIER_PERCEPTION: return Verifier::Perception;
  }
  return std::nullopt;
}

msg::Verifier to_msg(Verifier v) { return v == Verifier::Perception ? msg::VERIFIER_PERCEPTION : msg::VERIFIER_ORACLE; }

PlannerError from_msg(msg::PlannerError e) {
  const auto v = static_cast<int>(e);
  return v >= 0 && v <= static_cast<int>(PlannerError::RepeatedStep) ? static_cast<PlannerError>(v) : PlannerError::None;
}

msg::PlannerError to_msg(PlannerError e) { return static_cast<msg::PlannerError>(static_cast<int>(e)); }

PlannerRefusal from_msg(msg::PlannerRefusal r) {
  const auto v = static_cast<int>(r);
  return v >= 0 && v <= static_cast<int>(PlannerRefusal::Malformed) ? static_cast<PlannerRefusal>(v)
                                                                    : PlannerRefusal::None;
}

msg::PlannerRefusal to_msg(PlannerRefusal r) { return static_cast<msg::PlannerRefusal>(static_cast<int>(r)); }

std::map<std::string, double> from_msg(const std::vector<msg::Param>& p) {
  std::map<std::string, double> out;
  for (const auto& x : p) out[x.name()] = x.value();
  return out;
}

std::vector<msg::Param> to_msg(const std::map<std::string, double>& p) {
  std::vector<msg::Param> out;
  for (const auto& [name, value] : p) {
    msg::Param x;
    x.name(name);
    x.value(value);
    out.push_back(std::move(x));
  }
  return out;
}

SceneEstimate from_msg(const msg::SceneEstimate& m) {
  SceneEstimate e{m.episode_id(), m.step(), m.looked_for(), {}, {}};
  for (const auto& p : m.parts()) {
    PerceivedPart part{p.entity(), p.joint(), p.confidence(), {}};
    for (const auto& r : p.riders()) part.riders.push_back({r.entity(), r.p(), r.q()});
    e.parts.push_back(std::move(part));
  }
  for (const auto& p : m.seen()) {
    const auto& c = p.centroid();
    const auto& size = p.size();
    e.seen.push_back({p.entity(), {c[0], c[1], c[2] - size[2] / 2}, {size[0] / 2, size[1] / 2, size[2] / 2},
                      p.confidence(), p.yaw(), p.kind(), p.category(), p.colour()});
  }
  return e;
}

}  // namespace dh::convert

// The DDS-free codes mirror the IDL enums value for value: the shells cast between them.
static_assert(static_cast<int>(dh::msg::STATE_CANCELLED) == static_cast<int>(dh::CommandState::Cancelled));
static_assert(static_cast<int>(dh::msg::STATE_ACCEPTED) == static_cast<int>(dh::CommandState::Accepted));
static_assert(static_cast<int>(dh::msg::OUTCOME_SUCCESS) == static_cast<int>(dh::Outcome::Success));
static_assert(static_cast<int>(dh::msg::OUTCOME_REJECTED) == static_cast<int>(dh::Outcome::Rejected));
static_assert(static_cast<int>(dh::msg::FAILURE_PERCEPTION_LOST) == static_cast<int>(dh::FailureCode::PerceptionLost));
static_assert(static_cast<int>(dh::msg::SEAM_REJECTED_CHANNEL) == static_cast<int>(dh::SeamEventKind::RejectedChannel));
static_assert(static_cast<int>(dh::msg::SEAM_SAFETY_HOLD) == static_cast<int>(dh::SeamEventKind::SafetyHold));
static_assert(static_cast<int>(dh::msg::SEAM_SPEED_LIMITED) == static_cast<int>(dh::SeamEventKind::SpeedLimited));
static_assert(static_cast<int>(dh::msg::SEAM_ENDED) == static_cast<int>(dh::SeamEventKind::Ended));
