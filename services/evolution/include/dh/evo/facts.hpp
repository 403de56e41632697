// What attribution reads from one episode's evidence (JSON lines, dh/common/evidence.hpp): how it ended,
// its commands in dispatch order with their last status, the refusals, the missed deadlines, the
// verdict's changes and the planner's last word. Built from the records' codes (outcome, refusal,
// state, failure, wait, decision), never from their free text, so rewording a message changes nothing.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "dh/common/grounding_refusal.hpp"

namespace dh::evo {

struct CommandFacts {
  std::string id, capability, instance;
  nlohmann::json args = nlohmann::json::object();
  std::uint32_t dispatch_step = 0;
  bool recovery = false;  ///< dispatched by an insert_recovery decision
  /// Its last recorded status: accepted, running, completed, failed, refused, expired ("" when none came);
  /// "preempted" when the governor moved on (another dispatch, the end) before it reported an end.
  std::string state;
  std::string failure = "none", stage;
  std::uint32_t end_step = 0;  ///< the step of its last status
};

struct RefusalFacts {
  Refusal code = Refusal::PlannerRefused;  ///< why grounding refused
  std::string capability;  ///< the advised capability, when the record names it
};

/// Whether the command ended in failure: failed, refused or expired (not completed, preempted or running).
bool failed(const CommandFacts& c);

struct EpisodeFacts {
  bool ended = false;  ///< an episode_end record exists
  bool success = false;
  std::string outcome;  ///< success, budget_exhausted, gave_up, infrastructure, rejected
  std::uint32_t steps = 0;
  bool infrastructure = false;        ///< flagged lost (the campaign's row says so)
  std::vector<std::string> missing;   ///< capabilities it started without (capabilities_missing)
  bool capability_lost = false;       ///< the instance running its command lost its liveliness
  std::vector<std::string> missed_waits;  ///< deadline_missed "wait" codes, in order
  std::vector<RefusalFacts> refusals;     ///< in order
  std::vector<CommandFacts> commands;     ///< in dispatch order
  bool planner_done = false;      ///< the last advice said every step is done
  /// The last decision gave up on a completed command: a frozen plan (seq) run to its end, the goal unmet.
  bool gave_up_on_completion = false;
  bool verdict_lost = false;      ///< the task predicate held at some step and later did not
  bool latched = false;           ///< the governor's latch held at the end
  int last_stagnant = -1;         ///< stagnant decisions at the last decision (-1: no decision)
};

/// Reads `records` (one episode's evidence). `flagged_infrastructure`: the campaign's row says the
/// episode was lost to infrastructure. Throws std::runtime_error naming the record that lacks a field it
/// needs (evidence written by a build before attribution: run the episodes again with this one).
EpisodeFacts read_facts(const std::vector<nlohmann::json>& records, bool flagged_infrastructure = false);

}  // namespace dh::evo
