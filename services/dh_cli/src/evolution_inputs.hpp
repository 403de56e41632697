// What the evolution commands (dh probe, dh revise, dh gate) read from a campaign and the machine.
#pragma once

#include <string>
#include <vector>

#include "dh/common/episode_record.hpp"
#include "dh/evo/probe_set.hpp"

namespace dh::cli {

/// The episodes of `arm` in the campaign database `db`; std::invalid_argument when it has none.
std::vector<EpisodeRecord> arm_rows(const std::string& db, const std::string& arm);
/// Probes at once: `requested`, or every core when 0.
unsigned probe_jobs(unsigned requested);
/// Names on stderr each command of `set` whose probe could not run, and why.
void report_skipped(const evo::ProbeSet& set);

}  // namespace dh::cli
