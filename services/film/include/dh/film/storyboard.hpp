// What a film shows: the moments of an episode read from its evidence (the governor's records and the
// seam's step log), and the frames chosen among them. A frame is labelled with its step, the capability
// in control there, what happened at it, and the governor's last decision before it (not "continue").
//
// `auto` picks, in order of importance when there are more than the frame limit: refusals, recoveries,
// the episode's end (the latched verdict, or why it ended), each command's start, each command's end,
// and steps in the middle of each command that moved the arm (its middle, or its thirds when it ran for
// 60 steps or more). Moments at the same step share a
// frame. Labels are ASCII, as the strip's font draws them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace dh::film {

/// A governor decision other than "continue", at its step.
struct DecisionMark {
  std::uint32_t step = 0;
  std::string decision, reason;
};

/// A command as the evidence and the step log have it.
struct CommandSpan {
  std::string id, capability;
  std::uint32_t start_step = 0;
  std::optional<std::uint32_t> first_action_step, last_action_step;  ///< steps its actions led to
  bool recovery = false;                                               ///< dispatched after insert_recovery
  std::string end_state, end_reason;  ///< "refused", "completed", "failed", ... ("" when it never ended)
  std::uint32_t end_step = 0;
};

/// An episode as the film reads it.
struct Storyboard {
  std::string episode_id, arm, instruction, outcome, end_reason;
  bool latched = false;
  std::uint32_t steps = 0;  ///< the last recorded step
  std::uint32_t end_step = 0;
  std::optional<std::uint32_t> verdict_step;
  std::vector<CommandSpan> commands;
  std::vector<DecisionMark> decisions;
  std::vector<std::string> step_command;  ///< per step: the command whose action led to it ("" at step 0)
};

struct Frame {
  std::uint32_t step = 0;
  std::string capability;  ///< in control at the step ("a -> b" when control changed at it)
  std::string event;       ///< what the frame marks ("push refused: ...", "pick_place starts", ...)
  std::string decision;    ///< the last decision before it, "" when none
};

/// Reads `<episode>.jsonl` and the step log beside it. Throws std::runtime_error naming the file that is
/// missing or corrupt.
Storyboard read_storyboard(const std::filesystem::path& evidence);

/// The frames `auto` picks, at most `max_frames` (>= 1), in step order.
std::vector<Frame> auto_frames(const Storyboard& s, std::size_t max_frames);
/// Frames at the given steps, labelled the same way. Throws std::invalid_argument naming a step past the
/// episode's last.
std::vector<Frame> frames_at(const Storyboard& s, const std::vector<std::uint32_t>& steps);

/// "step 218 | pick_place", the event, and "after: <decision>" (the strip's three caption lines).
std::vector<std::string> caption(const Frame& f);

}  // namespace dh::film
