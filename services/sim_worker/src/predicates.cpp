#include "dh/sim/predicates.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dh::sim {

namespace {

// Which part (entity, part spec) an articulated predicate's argument names.
struct PartRef {
  const EntitySpec* entity = nullptr;
  const PartSpec* part = nullptr;
};

PartRef find_part(const SceneSpec& scene, const std::string& name, const std::string& term) {
  for (const auto& e : scene.entities) {
    if (e.name == name) {
      if (e.asset.parts.size() == 1) return {&e, &e.asset.parts.front()};
      if (e.asset.parts.empty()) throw std::invalid_argument(term + ": '" + name + "' has no articulated part");
      throw std::invalid_argument(term + ": '" + name + "' has " + std::to_string(e.asset.parts.size()) +
                                  " articulated parts; name one (e.g. a region on a drawer)");
    }
    for (const auto& p : e.asset.parts) {
      if (part_body(e.name, p.name) == name) return {&e, &p};
      for (const auto& s : p.sites)
        if (e.name + "_" + s.name == name) return {&e, &p};
    }
  }
  throw std::invalid_argument(term + ": no articulated part, region on a part, or single-part fixture named '" +
                              name + "' in scene " + scene.name);
}

std::string state_of(const std::string& predicate) {
  if (predicate == "Open") return "open";
  if (predicate == "Close") return "closed";
  if (predicate == "TurnOn") return "on";
  if (predicate == "TurnOff") return "off";
  return "";
}

/// The part an articulated term names and the joint interval of its state; throws naming the term.
struct StateRef {
  PartRef ref;
  std::array<double, 2> interval{};
};

StateRef find_state(const SceneSpec& scene, const PredicateSpec& p, const std::string& state) {
  if (p.args.size() != 1) throw std::invalid_argument(p.text() + ": " + p.name + " takes one argument");
  const PartRef ref = find_part(scene, p.args[0], p.text());
  const auto it = ref.part->joint.states.find(state);
  if (it == ref.part->joint.states.end())
    throw std::invalid_argument(p.text() + ": part '" + ref.part->name + "' of '" + ref.entity->name +
                                "' declares no '" + state + "' state");
  return {ref, it->second};
}

}  // namespace

std::vector<GoalTerm> goal_terms(const SceneSpec& scene, const std::vector<PredicateSpec>& goal) {
  std::vector<GoalTerm> out;
  for (const auto& p : goal) {
    GoalTerm t{p.name, p.args, "", 0, 0};
    const std::string state = state_of(p.name);
    if (!state.empty()) {
      const StateRef s = find_state(scene, p, state);
      t.part = part_body(s.ref.entity->name, s.ref.part->name);
      t.lo = s.interval[0];
      t.hi = s.interval[1];
    } else if (p.name != "On" && p.name != "In") {
      throw std::invalid_argument(p.text() + ": unknown predicate '" + p.name + "' (On, In, Open, Close, TurnOn, TurnOff)");
    } else if (p.args.size() != 2) {
      throw std::invalid_argument(p.text() + ": " + p.name + " takes two arguments");
    }
    out.push_back(std::move(t));
  }
  return out;
}

GoalEvaluator::GoalEvaluator(const mjModel_* m, const SceneSpec& scene, const std::vector<PredicateSpec>& goal)
    : m_(m) {
  for (const auto& p : goal) {
    const std::string term = p.text();
    Term t{};
    const std::string state = state_of(p.name);
    if (p.name == "On" || p.name == "In") {
      if (p.args.size() != 2) throw std::invalid_argument(term + ": " + p.name + " takes two arguments");
      t.body_a = mj_name2id(m, mjOBJ_BODY, p.args[0].c_str());
      if (t.body_a < 0 || !scene.entity(p.args[0]) || scene.entity(p.args[0])->fixture())
        throw std::invalid_argument(term + ": '" + p.args[0] + "' is not a movable object of scene " + scene.name);
      t.site = mj_name2id(m, mjOBJ_SITE, p.args[1].c_str());
      if (t.site >= 0) {
        t.kind = p.name == "On" ? Term::OnRegion : Term::InRegion;
        const int carrier = m->site_bodyid[t.site];
        const int root = m->body_rootid[carrier];
        if (carrier == 0) {
          t.support.push_back(0);
        } else {
          for (int b = 1; b < m->nbody; ++b)
            if (m->body_rootid[b] == root) t.support.push_back(b);
        }
      } else if (p.name == "On" && (t.body_b = mj_name2id(m, mjOBJ_BODY, p.args[1].c_str())) >= 0 &&
                 scene.entity(p.args[1])) {
        t.kind = Term::OnObject;
      } else {
        throw std::invalid_argument(term + ": no " + std::string(p.name == "On" ? "entity or region" : "region") +
                                    " named '" + p.args[1] + "' in scene " + scene.name);
      }
    } else if (!state.empty()) {
      const StateRef s = find_state(scene, p, state);
      const int j = mj_name2id(m, mjOBJ_JOINT, part_joint(s.ref.entity->name, s.ref.part->name).c_str());
      if (j < 0) throw std::invalid_argument(term + ": the model has no joint for '" + p.args[0] + "'");
      t.kind = Term::JointState;
      t.qpos = m->jnt_qposadr[j];
      t.lo = s.interval[0];
      t.hi = s.interval[1];
    } else {
      throw std::invalid_argument(term + ": unknown predicate '" + p.name +
                                  "' (On, In, Open, Close, TurnOn, TurnOff)");
    }
    terms_.push_back(std::move(t));
  }
}

bool GoalEvaluator::touches(const mjData_* d, int body, const std::vector<int>& others) const {
  for (int i = 0; i < d->ncon; ++i) {
    const int b1 = m_->geom_bodyid[d->contact[i].geom1], b2 = m_->geom_bodyid[d->contact[i].geom2];
    const int other = b1 == body ? b2 : b2 == body ? b1 : -1;
    if (other >= 0 && std::find(others.begin(), others.end(), other) != others.end()) return true;
  }
  return false;
}

bool GoalEvaluator::eval(const Term& t, const mjData_* d) const {
  switch (t.kind) {
    case Term::OnObject: {
      const double* pa = d->xpos + 3 * t.body_a;
      const double* pb = d->xpos + 3 * t.body_b;
      return pb[2] <= pa[2] && touches(d, t.body_a, {t.body_b}) &&
             std::hypot(pa[0] - pb[0], pa[1] - pb[1]) < kOnXyTolerance;
    }
    case Term::OnRegion:
    case Term::InRegion: {
      // a's origin in the site frame: R^T (p_a - p_site).
      const double* pa = d->xpos + 3 * t.body_a;
      const double* ps = d->site_xpos + 3 * t.site;
      const double* R = d->site_xmat + 9 * t.site;
      const double* h = m_->site_size + 3 * t.site;
      double v[3] = {pa[0] - ps[0], pa[1] - ps[1], pa[2] - ps[2]}, local[3];
      mju_mulMatTVec(local, R, v, 3, 3);
      if (std::abs(local[0]) >= h[0] || std::abs(local[1]) >= h[1]) return false;
      if (t.kind == Term::InRegion) return local[2] > -h[2] - kInLowerSlack && local[2] < h[2];
      return local[2] > h[2] - kRegionBelow && local[2] < h[2] + kRegionAbove && touches(d, t.body_a, t.support);
    }
    case Term::JointState: {
      const double q = d->qpos[t.qpos];
      return q >= t.lo && q <= t.hi;
    }
  }
  return false;
}

bool GoalEvaluator::holds(const mjData_* d) const {
  if (terms_.empty()) return false;
  return std::all_of(terms_.begin(), terms_.end(), [&](const Term& t) { return eval(t, d); });
}

}  // namespace dh::sim
