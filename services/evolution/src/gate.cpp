#include "dh/evo/gate.hpp"

#include <filesystem>
#include <tuple>

#include "dh/common/evidence.hpp"
#include "dh/evo/facts.hpp"

namespace dh::evo {
namespace {

using Key = std::tuple<std::string, unsigned, unsigned>;

std::string pair_text(const CellTask& d) { return d.first + "/" + std::to_string(d.second); }

}  // namespace

std::string contamination(const EpisodeRecord& r, const std::string& library_version,
                          const std::optional<std::string>& evidence_library,
                          const std::optional<bool>& evidence_success) {
  if (r.infrastructure) return "lost to infrastructure: " + r.reason;
  if (!evidence_library || !evidence_success)
    return "its evidence '" + r.evidence_path + "' is missing or does not validate";
  if (*evidence_library != library_version)
    return "ran library " + *evidence_library + ", not " + library_version;
  if (*evidence_success != r.success)
    return std::string("its evidence says ") + (*evidence_success ? "success" : "failure") +
           " where the campaign recorded " + (r.success ? "success" : "failure");
  return "";
}

std::vector<GateRow> gate_rows(const std::vector<EpisodeRecord>& rows, const AttributionConfig& config,
                               const std::string& library_version) {
  std::vector<GateRow> out;
  for (const EpisodeRecord& r : rows) {
    GateRow g;
    g.episode = {r.cell, r.task, r.seed, r.success && !r.infrastructure, false, false};
    std::optional<std::string> evidence_library;
    std::optional<bool> evidence_success;
    std::string invalid;  // why the evidence does not validate
    try {
      if (r.evidence_path.empty() || !std::filesystem::exists(r.evidence_path))
        throw std::runtime_error("no evidence");
      const auto records = read_evidence(r.evidence_path);
      for (const auto& e : records) {
        if (e.value("kind", "") == "episode_start") evidence_library = e.value("library_version", "");
        if (e.value("kind", "") == "episode_end") evidence_success = e.value("success", false);
      }
      if (!g.episode.success) {
        if (const auto a = attribute(read_facts(records, r.infrastructure), config)) {
          g.episode.harness_failure = a->harness;
          g.signature = a->signature;
        }
      }
    } catch (const std::exception& e) {
      evidence_library.reset();  // does not validate: contaminated when checked
      evidence_success.reset();
      invalid = e.what();
    }
    if (!library_version.empty()) {
      g.contamination = contamination(r, library_version, evidence_library, evidence_success);
      if (!invalid.empty() && !r.infrastructure) g.contamination += " (" + invalid + ")";
      g.episode.contaminated = !g.contamination.empty();
    }
    out.push_back(std::move(g));
  }
  return out;
}

std::string dominant_capability(const std::vector<GateRow>& rows, const std::set<std::string>& revisable) {
  std::map<std::string, unsigned> count;
  for (const auto& r : rows)
    if (r.episode.harness_failure && r.signature && revisable.count(r.signature->capability))
      ++count[r.signature->capability];
  std::string best;
  unsigned most = 0;
  for (const auto& [capability, n] : count)  // in name order: a tie keeps the first
    if (n > most) {
      best = capability;
      most = n;
    }
  return best;
}

GateResult paired_gate(const std::vector<GateEpisode>& parent, const std::vector<GateEpisode>& candidate,
                       const std::vector<GateEpisode>& bare, const std::set<CellTask>& targeted) {
  GateResult g;
  std::map<Key, const GateEpisode*> by_key;
  for (const auto& e : candidate)
    if (targeted.count({e.cell, e.task})) by_key[{e.cell, e.task, e.seed}] = &e;
  long contaminated = 0;
  std::set<Key> paired;
  for (const auto& p : parent) {
    if (!targeted.count({p.cell, p.task})) continue;
    const auto c = by_key.find({p.cell, p.task, p.seed});
    if (c == by_key.end()) {
      g.unpaired.push_back(p.cell + "/" + std::to_string(p.task) + " seed " + std::to_string(p.seed));
      continue;
    }
    paired.insert(c->first);
    PairCounts& n = g.pairs[{p.cell, p.task}];
    ++n.n;
    n.parent_s += p.success;
    n.parent_u += p.harness_failure;
    n.candidate_s += c->second->success;
    n.candidate_u += c->second->harness_failure;
  }
  for (const auto& [key, e] : by_key) contaminated += e->contaminated;
  // D_π: pairs of D the bare arm wins, on the seeds paired here.
  std::map<CellTask, std::pair<unsigned, unsigned>> bare_wins;  // successes, episodes
  for (const auto& b : bare)
    if (paired.count({b.cell, b.task, b.seed})) {
      auto& w = bare_wins[{b.cell, b.task}];
      w.first += b.success;
      ++w.second;
    }
  for (auto& [d, n] : g.pairs) {
    const auto w = bare_wins.find(d);
    n.in_pi = w != bare_wins.end() && 2 * w->second.first > w->second.second;
    g.pi_vacuous &= !n.in_pi;
  }

  GateCondition s{"successes", true, 0, 0, ""}, u{"harness_failures", true, 0, 0, ""};
  GateCondition pi{"bare_policy_pairs", true, 0, 0, ""},
      x{"contaminated", contaminated == 0, contaminated, 0, ""};
  for (const auto& [d, n] : g.pairs) {
    s.candidate += n.candidate_s;
    s.parent += n.parent_s;
    u.candidate += n.candidate_u;
    u.parent += n.parent_u;
    if (!n.in_pi) continue;
    pi.candidate += n.candidate_s;
    pi.parent += n.parent_s;
    if (n.candidate_s < n.parent_s) {
      pi.pass = false;
      pi.detail += (pi.detail.empty() ? "" : ", ") + pair_text(d) + " " + std::to_string(n.candidate_s) +
                   " < " + std::to_string(n.parent_s);
    }
  }
  s.pass = s.candidate >= s.parent;
  u.pass = u.candidate <= u.parent;
  if (g.pi_vacuous) pi.detail = "vacuous: the bare arm wins no pair of D on these seeds";
  if (!x.pass) x.detail = std::to_string(contaminated) + " of the candidate's episodes in D do not count";
  g.conditions = {s, u, pi, x};
  g.pass = g.unpaired.empty() && !g.pairs.empty() && s.pass && u.pass && pi.pass && x.pass;
  return g;
}

RegressionResult broader_regression(const std::vector<GateEpisode>& parent,
                                    const std::vector<GateEpisode>& candidate,
                                    const std::set<std::string>& cells) {
  RegressionResult r;
  std::map<Key, const GateEpisode*> by_key;
  std::set<std::string> ran;
  for (const auto& e : candidate) {
    by_key[{e.cell, e.task, e.seed}] = &e;
    ran.insert(e.cell);
  }
  for (const auto& p : parent) {
    const std::string key = p.cell + "/" + std::to_string(p.task) + " seed " + std::to_string(p.seed);
    const auto c = by_key.find({p.cell, p.task, p.seed});
    if (c == by_key.end()) {
      r.unpaired.push_back(key);
      continue;
    }
    ++r.paired;
    r.parent += p.success;
    r.candidate += c->second->success;
    r.contaminated += c->second->contaminated;
    if (p.success && !c->second->success) r.lost.push_back(key);
    if (!p.success && c->second->success) r.gained.push_back(key);
  }
  for (const auto& cell : cells)
    if (!ran.count(cell)) r.missing_cells.push_back(cell);
  r.pass = r.unpaired.empty() && r.missing_cells.empty() && r.contaminated == 0 && r.paired > 0 &&
           r.candidate >= r.parent;
  return r;
}

}  // namespace dh::evo
