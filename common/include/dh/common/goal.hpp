// A task's goal as the governor judges it from what it sees (issue 19's verdict from perception): each
// term resolved against the cell's description by whoever asks for the episode, so the governor needs
// neither the scene's files nor the simulator. The simulator's (or a benchmark's) own verdict is the oracle.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dh {

/// One conjunct of a goal: On(a, b), In(a, region), or an articulated part's state (Open, Close, TurnOn,
/// TurnOff), which names the part's entity in the observation and the joint interval of that state.
struct GoalTerm {
  std::string predicate;          ///< On | In | Open | Close | TurnOn | TurnOff
  std::vector<std::string> args;  ///< as the task writes them
  std::string part;               ///< articulated terms: the part entity whose joint decides
  double lo = 0, hi = 0;          ///< articulated terms: the state's joint interval (m or rad)
  bool articulated() const { return !part.empty(); }
  std::string text() const;  ///< "On(bowl, plate)"
};

/// Which verdict the governor latches and ends on (idl Verifier: the same values in the same order).
enum class Verifier : std::uint8_t {
  Oracle,      ///< the simulator's (benchmark's) predicate, reported with every observation
  Perception,  ///< the goal evaluated on the perceived world, k frames in agreement
};
const char* to_string(Verifier v);
/// "oracle" | "perception"; throws std::invalid_argument naming the value and the choices.
Verifier parse_verifier(const std::string& text);

}  // namespace dh
