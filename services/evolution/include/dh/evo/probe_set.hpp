// A capability's probe set (issue 16): the command states a revision of that capability is judged on.
// Every command of the capability is probed first under the θ it recorded (the parent library): those
// whose effect did not hold (or, judged by the rest of the episode, whose episode failed) are the failing
// states (a typed failure, an expiry, or a completion without
// its effect), and as many of those whose effect held (at least `min_successes`) are drawn by seed: the
// successes guard against a revision that fixes one state and breaks others. Probes run in parallel, one
// workcell per thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dh/common/episode_record.hpp"
#include "dh/evo/probe.hpp"

namespace dh::evo {

struct ProbeState {
  std::filesystem::path evidence;
  std::uint32_t command = 0;  ///< K, 0-based in dispatch order
  bool failing = false;       ///< it did not pass (ProbeReport::passed) under the recorded θ
  std::string label;          ///< "goal-task/1 seed 21 command 0"
};

struct ProbeSetOptions {
  std::string capability;
  std::size_t min_successes = 20;
  std::uint64_t draw_seed = 0;
  /// Judge each state by the rest of its episode run from it (its success), not by the command's effect:
  /// a θ whose effect was never the trouble (a cost that leaves a later step no budget, an effect a later
  /// step undoes) is then seen. The states are then drawn by their episodes' recorded outcomes and only
  /// those drawn are probed (under the recorded θ the rest reproduces the recorded episode).
  bool rest = false;
  /// Asked before each probe: true ends the probing (ProbesInterrupted), as Ctrl-C does.
  std::function<bool()> stop = nullptr;
};

/// A run of probes asked to stop before every state was probed.
struct ProbesInterrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ProbeOutcome {
  ProbeState state;
  std::optional<ProbeReport> report;  ///< none when the probe could not run
  std::string error;
};

struct ProbeSet {
  std::vector<ProbeOutcome> states;  ///< failing states first, in the rows' order, then the drawn successes
  std::vector<ProbeOutcome>
      skipped;  ///< commands whose probe could not run (never started, files missing), with why
};

/// The probe set over `rows` (a campaign's episodes, one arm), probed on `jobs` threads under each
/// command's recorded θ. Episodes without evidence, lost to infrastructure or grounded in perception give
/// none. Throws std::invalid_argument when `options.capability` is not an analytic or recovery skill of
/// this build, inproc::EvidenceError naming an evidence file that does not read.
ProbeSet probe_set(const std::vector<EpisodeRecord>& rows, const ProbeSetOptions& options,
                   const std::filesystem::path& config_dir, unsigned jobs);

/// Probes every state under `library_dir`, or else `theta` for the commands' capability, or else each
/// recording's own θ, on `jobs` threads, with the rest of each episode when `rest`; results in the
/// states' order. `stop` is asked before each probe; once it says true no probe starts, the running ones
/// end, and ProbesInterrupted is thrown.
std::vector<ProbeOutcome> probe_states(const std::vector<ProbeState>& states,
                                       const std::filesystem::path& config_dir,
                                       const std::filesystem::path& library_dir, unsigned jobs,
                                       const std::optional<cap::Theta>& theta = std::nullopt,
                                       bool rest = false, const std::function<bool()>& stop = {});

/// One state probed `repeats` times: how many runs passed, and whether every run ended as the first did.
struct RepeatedProbe {
  std::vector<ProbeOutcome> runs;
  unsigned passed = 0;
  std::optional<std::size_t> first_different;  ///< the first run whose result is not run 0's (same_result)
  /// The first error of a run that could not probe; then the others are not compared.
  std::string error;
  /// Every run probed and ended as the first did.
  bool alike() const { return !first_different && error.empty(); }
};

/// Probes every state `repeats` times, all runs spread over `jobs` threads (so repeats of one state run
/// side by side, each on its own workcell), as probe_states does; results in the states' order.
std::vector<RepeatedProbe> probe_repeats(const std::vector<ProbeState>& states,
                                         const std::filesystem::path& config_dir,
                                         const std::filesystem::path& library_dir, unsigned repeats,
                                         unsigned jobs, bool rest = false);

}  // namespace dh::evo
