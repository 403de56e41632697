#include "dh/evo/probe_set.hpp"

#include <algorithm>
#include <atomic>
#include <iterator>
#include <random>
#include <stdexcept>
#include <thread>

#include "dh/cap/library.hpp"
#include "dh/common/arms.hpp"
#include "dh/inproc/recording.hpp"

namespace dh::evo {

namespace {

/// `k` of `n` indices drawn by `seed`, in order (all of them when there are fewer).
std::vector<std::size_t> draw(std::size_t n, std::size_t k, std::uint64_t seed) {
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), std::mt19937_64(seed));
  order.resize(std::min(n, k));
  std::sort(order.begin(), order.end());
  return order;
}

}  // namespace

ProbeSet probe_set(const std::vector<EpisodeRecord>& rows, const ProbeSetOptions& o,
                   const std::filesystem::path& config_dir, unsigned jobs) {
  if (!cap::find_capability(cap::all_capabilities(), o.capability))
    throw std::invalid_argument("'" + o.capability +
                                "' is not an analytic or recovery skill of this build: a probe "
                                "cannot re-run it");
  const auto arms = load_arms(config_dir / "governor.yaml");
  std::vector<ProbeState> all;
  for (const EpisodeRecord& r : rows) {
    if (r.infrastructure || r.evidence_path.empty() || !std::filesystem::exists(r.evidence_path)) continue;
    if (find_arm(arms, r.arm).grounding == "perception") continue;  // a probe re-makes no estimates
    const inproc::Recording rec = inproc::read_recording(r.evidence_path);
    for (std::size_t k = 0; k < rec.commands.size(); ++k)
      if (rec.commands[k].capability == o.capability)
        all.push_back({r.evidence_path, static_cast<std::uint32_t>(k), o.rest && !r.success,
                       r.cell + "/" + std::to_string(r.task) + " seed " + std::to_string(r.seed) +
                           " command " + std::to_string(k)});
  }
  ProbeSet set;
  if (o.rest) {
    // Judged by the rest of the episode: under the recorded θ that is the recorded episode (a rest
    // reproduces it bit for bit), so the states are classed by the recorded outcome and only those
    // chosen are probed; a probe's own result still decides.
    std::vector<ProbeState> chosen, won;
    for (auto& s : all) (s.failing ? chosen : won).push_back(std::move(s));
    for (std::size_t i : draw(won.size(), std::max(o.min_successes, chosen.size()), o.draw_seed))
      chosen.push_back(std::move(won[i]));
    for (auto& p : probe_states(chosen, config_dir, {}, jobs, std::nullopt, true, o.stop)) {
      if (!p.report) {
        set.skipped.push_back(std::move(p));
        continue;
      }
      p.state.failing = !p.report->passed();
      set.states.push_back(std::move(p));
    }
    std::stable_partition(set.states.begin(), set.states.end(),
                          [](const ProbeOutcome& p) { return p.state.failing; });
    return set;
  }
  std::vector<ProbeOutcome> parent = probe_states(all, config_dir, {}, jobs, std::nullopt, false, o.stop);
  std::vector<ProbeOutcome> failing, held;
  for (auto& p : parent) {
    if (!p.report) {
      set.skipped.push_back(std::move(p));
      continue;
    }
    p.state.failing = !p.report->passed();
    (p.state.failing ? failing : held).push_back(std::move(p));
  }
  // The successes kept: a draw by seed, listed in the rows' order.
  for (std::size_t i : draw(held.size(), std::max(o.min_successes, failing.size()), o.draw_seed))
    failing.push_back(std::move(held[i]));
  set.states = std::move(failing);
  return set;
}

std::vector<ProbeOutcome> probe_states(const std::vector<ProbeState>& states,
                                       const std::filesystem::path& config_dir,
                                       const std::filesystem::path& library_dir, unsigned jobs,
                                       const std::optional<cap::Theta>& theta, bool rest,
                                       const std::function<bool()>& stop) {
  std::vector<ProbeOutcome> out(states.size());
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stopped{false};
  // Each probe owns its workcell, host and seam; MuJoCo models and data are not shared between threads
  // (as the simulator worker runs one channel per thread).
  const auto work = [&] {
    for (std::size_t i = next++; i < states.size(); i = next++) {
      if (stopped || (stop && stop())) {
        stopped = true;
        return;
      }
      out[i].state = states[i];
      try {
        out[i].report = probe(states[i].evidence, {config_dir, library_dir, states[i].command, theta, rest, {}});
      } catch (const std::exception& e) {
        out[i].error = e.what();
      }
    }
  };
  std::vector<std::thread> threads;
  for (unsigned j = 1; j < std::max(1u, jobs); ++j) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
  if (stopped)
    throw ProbesInterrupted("probing interrupted before all " + std::to_string(states.size()) +
                            " probes ran");
  return out;
}

std::vector<RepeatedProbe> probe_repeats(const std::vector<ProbeState>& states,
                                         const std::filesystem::path& config_dir,
                                         const std::filesystem::path& library_dir, unsigned repeats,
                                         unsigned jobs, bool rest) {
  if (repeats == 0) throw std::invalid_argument("--repeats 0: a probe runs at least once");
  std::vector<ProbeState> runs;
  for (const auto& s : states) runs.insert(runs.end(), repeats, s);
  std::vector<ProbeOutcome> all = probe_states(runs, config_dir, library_dir, jobs, std::nullopt, rest);
  std::vector<RepeatedProbe> out(states.size());
  for (std::size_t i = 0; i < states.size(); ++i) {
    RepeatedProbe& r = out[i];
    r.runs.assign(std::make_move_iterator(all.begin() + i * repeats),
                  std::make_move_iterator(all.begin() + (i + 1) * repeats));
    for (std::size_t k = 0; k < r.runs.size(); ++k) {
      const ProbeOutcome& run = r.runs[k];
      if (!run.report) {
        if (r.error.empty()) r.error = run.error;
        continue;
      }
      r.passed += run.report->passed();
      if (!r.first_different && r.runs[0].report && !same_result(*r.runs[0].report, *run.report))
        r.first_different = k;
    }
  }
  return out;
}

}  // namespace dh::evo
