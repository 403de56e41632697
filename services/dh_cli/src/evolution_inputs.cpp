#include "evolution_inputs.hpp"

#include <algorithm>
#include <iostream>
#include <stdexcept>
#include <thread>

#include "dh/campaign/db.hpp"

namespace dh::cli {

std::vector<EpisodeRecord> arm_rows(const std::string& db, const std::string& arm) {
  std::vector<EpisodeRecord> rows;
  for (auto& r : campaign::CampaignDb::read_rows(db))
    if (r.arm == arm) rows.push_back(std::move(r));
  if (rows.empty()) throw std::invalid_argument(db + " has no episode of arm " + arm);
  return rows;
}

unsigned probe_jobs(unsigned requested) {
  return requested ? requested : std::max(1u, std::thread::hardware_concurrency());
}

void report_skipped(const evo::ProbeSet& set) {
  for (const auto& s : set.skipped)
    std::cerr << "skipped " << s.state.label << " (" << s.state.evidence.string() << "): " << s.error << "\n";
}

}  // namespace dh::cli
