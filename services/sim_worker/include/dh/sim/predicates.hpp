// The benchmark's goal predicates, evaluated from simulator state with LIBERO's geometric meaning:
//   On(a, b)       b an object: b not above a, a and b in contact, origins within 3 cm horizontally.
//   On(a, region)  a's origin over the region box: |dx|, |dy| inside its half sizes and
//                  half_z - 5 mm < dz < half_z + 10 cm above the box centre (the box's top face is the
//                  surface); plus contact between a and the entity carrying the region (the table for
//                  table regions).
//   In(a, region)  a's origin inside the region box (its lower face lowered by 1 cm).
//   Open/Close/TurnOn/TurnOff(x)  the joint of x within the interval its asset names open/closed/on/off.
//                  x is a fixture with one articulated part, a part ("cabinet_top_drawer") or a region
//                  on a part ("cabinet_top_region" names the top drawer).
// A goal is the conjunction of its terms.
#pragma once

#include <string>
#include <vector>

#include "dh/common/goal.hpp"
#include "dh/common/suite.hpp"
#include "dh/sim/scene.hpp"

struct mjModel_;
struct mjData_;

namespace dh::sim {

inline constexpr double kOnXyTolerance = 0.03;      ///< On(a, object): origin distance (m)
inline constexpr double kRegionBelow = 0.005;       ///< On(a, region): below the surface allowed (m)
inline constexpr double kRegionAbove = 0.10;        ///< On(a, region): above the surface allowed (m)
inline constexpr double kInLowerSlack = 0.01;       ///< In(a, region): the box's floor lowered by (m)

/// The goal's terms as the governor judges them from what it sees (dh/common/goal.hpp): an articulated
/// term names its part's entity and the joint interval of its state. Throws std::invalid_argument naming
/// the term, as GoalEvaluator does, for a part or state the scene lacks or an unknown predicate.
std::vector<GoalTerm> goal_terms(const SceneSpec& scene, const std::vector<PredicateSpec>& goal);

class GoalEvaluator {
 public:
  /// Resolves every term against the compiled model; throws std::invalid_argument naming the term and the
  /// entity, region or state the scene lacks.
  GoalEvaluator(const mjModel_* m, const SceneSpec& scene, const std::vector<PredicateSpec>& goal);

  /// The conjunction; an empty goal never holds.
  bool holds(const mjData_* d) const;

 private:
  struct Term {
    enum Kind { OnObject, OnRegion, InRegion, JointState } kind;
    int body_a = -1, body_b = -1;   ///< OnObject
    int site = -1;                  ///< OnRegion, InRegion
    std::vector<int> support;       ///< OnRegion: bodies a must touch
    int qpos = -1;                  ///< JointState
    double lo = 0, hi = 0;
  };
  bool eval(const Term& t, const mjData_* d) const;
  bool touches(const mjData_* d, int body, const std::vector<int>& others) const;

  const mjModel_* m_;
  std::vector<Term> terms_;
};

}  // namespace dh::sim
