// Decision and planner latencies read from one episode's evidence file.
#pragma once

#include <string>
#include <vector>

namespace dh::report {

struct Latencies {
  std::vector<double> decision_ms;  ///< "decision" records' latency_ns
  std::vector<double> planner_ms;   ///< "plan_request" → the later "advice" with the same request_id
  unsigned unanswered = 0;          ///< plan requests no advice answered
  void merge(const Latencies& other);
};

enum class EvidenceStatus { Read, Missing, NotRecorded };

/// Adds the latencies of the evidence file at `path` to `into`. "" is NotRecorded; a file that cannot be
/// read is Missing and adds nothing; records with absent or mistyped fields are skipped.
EvidenceStatus collect_latencies(const std::string& path, Latencies& into);

}  // namespace dh::report
