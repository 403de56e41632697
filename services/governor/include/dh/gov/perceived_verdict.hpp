// The task's verdict from what perception sees (issue 19): the goal's terms evaluated on the perceived
// world, frame by frame, for a cell with no oracle. Pure logic, no DDS.
//
// Without the simulator's contacts, "touches" becomes "rests": an object counts as placed when its
// perceived bottom lies within a band of the support's top and the jaw does not hold it. On a region
// "on" a fixture, the support is the region's top face or the fixture's top over the region's footprint
// (a wine rack's cradle: the region is its floor, a bowl rests on its rails). The bands are
// declared below, chosen from perception's accuracy (its boxes' bottoms are within about 1 cm), not fitted
// to any block of episodes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dh/common/goal.hpp"
#include "dh/common/observation.hpp"

namespace dh::gov {

inline constexpr double kPerceivedOnXy = 0.03;      ///< On(a, object): bottom centres within (m), as the oracle's
inline constexpr double kPerceivedRestBelow = 0.02; ///< a rests on a surface: its bottom at most this below it (m)
inline constexpr double kPerceivedRestAbove = 0.03; ///< ... and at most this above it (m)
inline constexpr double kPerceivedInFloor = 0.02;   ///< In(a, region): the region's floor lowered by (m)

/// Whether `term` holds in `seen` (an observation as perception sees it). An entity the view lacks (never
/// seen) makes its term false.
bool term_holds(const GoalTerm& term, const Observation& seen);

/// One term judged twice, for attributing a disagreement with the simulator: on the perceived view and,
/// where the observation carries the simulator's poses of the term's entities, on those true poses with
/// the same bands. A term false on true poses while the oracle holds is the band's disagreement with the
/// simulator's contacts; true on true poses but false as perceived is perception's error.
struct TermCheck {
  std::string term;                  ///< "On(bowl, plate)"
  std::string subject;               ///< the entity that moves: the first argument, or the part
  bool perceived = false;
  std::optional<bool> on_true_poses; ///< unset on a cell (no simulator poses)
  const EntityState* seen = nullptr; ///< the subject in the perceived view; null when never seen
  const EntityState* truth = nullptr;
  /// On(a, b) with b an object: b as perceived and as it is (a support's own estimate can be off too)
  const EntityState* support_seen = nullptr;
  const EntityState* support_truth = nullptr;
};
std::vector<TermCheck> check_terms(const std::vector<GoalTerm>& goal, const Observation& seen, const Observation& truth);

/// The goal's verdict from consecutive perceived frames: the verdict changes only when `frames` frames in a
/// row agree on the other value, so one false frame cannot latch success (nor lose it).
class PerceivedVerdict {
 public:
  PerceivedVerdict(std::vector<GoalTerm> goal, std::uint32_t frames);

  struct Change {
    std::uint32_t step = 0;  ///< the frame that made the run `frames` long
    bool value = false;
  };
  /// One frame's view at control step `step`; an older frame is ignored. Frames of one step count one by
  /// one: while the robot stands still the camera keeps looking (the perception service's idle frames).
  std::optional<Change> on_frame(std::uint32_t step, const Observation& seen);

  bool value() const { return value_; }

  /// What the frames so far left, for an episode's snapshot.
  struct State {
    bool value = false;
    std::uint32_t run = 0;
    std::optional<std::uint32_t> last_step;
  };
  State state() const { return {value_, run_, last_step_}; }
  void restore(const State& s) {
    value_ = s.value;
    run_ = s.run;
    last_step_ = s.last_step;
  }

 private:
  std::vector<GoalTerm> goal_;
  std::uint32_t frames_;
  bool value_ = false;
  std::uint32_t run_ = 0;  ///< frames in a row that disagree with value_
  std::optional<std::uint32_t> last_step_;
};

}  // namespace dh::gov
