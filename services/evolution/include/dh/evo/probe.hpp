// The probe (issue 16): a recorded command re-run from the state the harness left the arm in. The
// workcell is restored to the physics state recorded at command K's start, the capability host core to
// the keyframes the earlier commands left, and K runs again on the in-process bus — the same host and seam
// cores the services run — under the parent library (the θ the episode recorded) or a candidate's.
// It reports how the command ended, whether its effect held (effect.hpp), and, step by step, whether
// the physics followed the recording: under the parent library a probe reproduces the recorded command
// bit for bit.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "dh/cap/skill.hpp"
#include "dh/inproc/recording.hpp"
#include "dh/inproc/replay.hpp"

namespace dh::evo {

struct ProbeOptions {
  std::filesystem::path config_dir;   ///< suites, scenes, arms
  std::filesystem::path library_dir;  ///< a candidate library; empty: the θ the episode recorded (the parent)
  std::uint32_t command = 0;          ///< K, 0-based in dispatch order
  std::optional<cap::Theta> theta;    ///< without library_dir: a candidate θ of the command's capability
  /// Runs the rest of the episode after command K, the governor's core restored from its snapshot at K's
  /// dispatch (inproc::Stack::resume), instead of command K alone. Its evidence goes to `rest_evidence`
  /// (empty: a temporary file, removed).
  bool rest = false;
  std::filesystem::path rest_evidence;
};

/// How the rest of the episode went, beside how the recording went.
struct RestReport {
  bool success = false;
  std::string outcome, reason;
  std::uint32_t steps = 0;
  std::optional<inproc::RecordedEpisodeEnd> recorded;  ///< none: the recording has no episode end
};

struct ProbeReport {
  std::string episode_id, command_id, capability;
  std::string library;          ///< "recorded", the candidate library's version (lib-...) or "theta lib-..."
  nlohmann::json theta;         ///< the θ the command ran with
  std::uint32_t from_step = 0;  ///< the restored state's step (the command's start)
  std::uint32_t end_step = 0;   ///< the step its end was reported at
  std::uint32_t budget_steps = 0;
  std::string state, failure, stage, reason;  ///< how it ended (CommandState, FailureCode as text)
  std::string effect;        ///< the effect's predicates, or "completion" when its arguments name none
  bool effect_held = false;  ///< the effect's predicates hold at the command's end (or it completed)
  // Against the recording:
  std::optional<inproc::RecordedEnd> recorded;  ///< none: the governor moved on before the command ended
  bool same_end = false;                        ///< state, failure, stage and step as recorded
  std::uint32_t steps_compared = 0;             ///< steps whose physics digest was compared with the step log
  std::optional<inproc::Divergence> first_divergence;
  bool reproduces = false;  ///< every compared step identical, and the recorded end (if any) the same
  std::optional<RestReport> rest;  ///< with ProbeOptions::rest; then `reproduces` also asks the same episode end
  /// The physics state's digest (sim::StateDigest::state) after the last step run.
  std::uint64_t end_digest = 0;
  /// What a probe set counts: with the rest of the episode, its success; else the command's effect.
  bool passed() const { return rest ? rest->success : effect_held; }
};

/// Probes command `options.command` of the episode recorded at `evidence` (with its .steps and .states
/// beside it). Throws inproc::EvidenceError naming the file for missing or corrupt recordings,
/// std::invalid_argument for a command number out of range or a command the probe cannot re-run (one
/// grounded in perception without `rest`, or a capability that is not an analytic or recovery skill of
/// this build),
/// cap's ConfigError for a candidate library that does not load; with `rest`, EvidenceError for evidence
/// without the governor's snapshot at K. A candidate θ whose cost exceeds what
/// the episode had left is refused, as the governor refuses it, without running.
ProbeReport probe(const std::filesystem::path& evidence, const ProbeOptions& options);

/// Two probes of one state ended alike: the same end (state, failure, stage, step), effect, rest of the
/// episode and physics state at the end. On the in-process bus a probe is deterministic, so repeats do.
bool same_result(const ProbeReport& a, const ProbeReport& b);

nlohmann::json to_json(const ProbeReport& r);

}  // namespace dh::evo
