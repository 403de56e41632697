// dh report (campaign databases → Markdown, HTML, PNG), dh stats (the same statistics by hand),
// dh seeds (a fresh block of seeds for post-selection tests).
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/stats.hpp"
#include "dh/evo/attribution.hpp"
#include "dh/film/film.hpp"
#include "dh/report/report.hpp"

namespace dh::cli {
namespace {

// Whether the episode's evidence grounded `capability` (a door episode: swing_door). Only the lines that
// name both a grounding and the capability are parsed: a campaign without a door episode is read once,
// quickly, rather than parsed record by record.
bool dispatched(const std::string& evidence, const std::string& capability) {
  std::ifstream in(evidence);
  for (std::string line; std::getline(in, line);) {
    if (line.find("\"grounding\"") == std::string::npos || line.find(capability) == std::string::npos) continue;
    const auto r = nlohmann::json::parse(line, nullptr, false);
    if (r.is_object() && r.value("kind", "") == "grounding" && r.value("capability", "") == capability) return true;
  }
  return false;
}

// The episodes to film. auto: the paper's cases where the campaign has them: Figure 3's refused push
// (goal-swap 5, the lowest seed), a door episode (the first that dispatched swing_door), and a
// long-horizon one (the first of a long cell), each of the full arm when it ran. Else ARM/CELL/TASK/SEED.
std::vector<std::pair<const EpisodeRecord*, std::string>> films_to_make(const std::vector<report::Source>& sources,
                                                                         const std::string& spec) {
  std::vector<const EpisodeRecord*> rows;
  for (const auto& s : sources)
    for (const auto& r : s.rows) rows.push_back(&r);
  std::stable_sort(rows.begin(), rows.end(), [](const EpisodeRecord* x, const EpisodeRecord* y) {
    return (x->arm == "full") > (y->arm == "full");
  });
  std::vector<std::pair<const EpisodeRecord*, std::string>> out;
  if (spec == "none") return out;
  if (spec != "auto") {
    for (const auto& key : campaign::parse_list(spec, "--films")) {
      const auto it = std::find_if(rows.begin(), rows.end(), [&](const EpisodeRecord* r) {
        return r->arm + "/" + r->cell + "/" + std::to_string(r->task) + "/" + std::to_string(r->seed) == key;
      });
      if (it == rows.end()) throw std::invalid_argument("--films " + key + ": no such episode (ARM/CELL/TASK/SEED) in the databases");
      out.emplace_back(*it, key);
    }
    return out;
  }
  const EpisodeRecord* fig3 = nullptr;
  for (const auto* r : rows)
    if (r->cell == "goal-swap" && r->task == 5 && (!fig3 || (r->arm == fig3->arm && r->seed < fig3->seed))) fig3 = r;
  if (fig3) out.emplace_back(fig3, "Figure 3's case: the refused push and the substituted pick and place");
  for (const auto* r : rows)
    if (dispatched(r->evidence_path, "swing_door")) {
      out.emplace_back(r, "a door episode");
      break;
    }
  for (const auto* r : rows)
    if (r->cell.rfind("long", 0) == 0 && !r->evidence_path.empty()) {
      out.emplace_back(r, "a long-horizon episode");
      break;
    }
  return out;
}

}  // namespace

int cmd_report(const ReportArgs& a) {
  // Failures by layer, when `dh attribute` labelled them under this attribution file (none: no section).
  const std::filesystem::path attribution_file =
      a.attribution.empty() ? paths::config_dir() / "attribution.yaml" : std::filesystem::path(a.attribution);
  std::string attribution;
  if (std::filesystem::exists(attribution_file))
    attribution = evo::config_version(evo::load_attribution(attribution_file));
  else if (!a.attribution.empty())
    throw std::invalid_argument("--attribution " + a.attribution + ": no such file");
  std::vector<report::Source> sources;
  for (const auto& db : a.dbs) {
    report::Source s{db, campaign::CampaignDb::read_rows(db), {}};
    if (!attribution.empty())
      for (const auto& r : campaign::CampaignDb::read_attributions(db, attribution))
        s.attributed.push_back({r.arm, r.cell, r.task, r.seed, r.layer, r.name, r.harness});
    sources.push_back(std::move(s));
  }
  report::ReportOptions options;
  options.attribution_config = attribution;
  options.title = a.title;
  options.bootstrap_resamples = a.resamples;
  options.bootstrap_seed = a.bootstrap_seed;
  options.plots = a.plots;
  options.policy_dir = a.policy_dir;
  for (const auto& [cell, suite] : load_suites(paths::config_dir()))
    if (suite.perturbation == "pos") options.positions[cell] = suite.tasks.begin()->second.pos;
  if (a.json && a.out.empty()) {
    std::cout << report::summarize(sources, options).dump() << "\n";
    return 0;
  }
  const std::filesystem::path first(a.dbs.front());
  options.out_dir = a.out.empty() ? first.parent_path() / (first.stem().string() + "-report") : std::filesystem::path(a.out);
  for (const auto& [row, why] : films_to_make(sources, a.films)) {
    const std::string name = row->arm + "_" + row->cell + "_" + std::to_string(row->task) + "_" + std::to_string(row->seed);
    report::ReportOptions::Film f{"films/" + name + ".png",
                                  why + ": " + row->arm + " arm, " + row->cell + " task " + std::to_string(row->task) +
                                      " seed " + std::to_string(row->seed) + " (" + row->outcome + ")",
                                  ""};
    try {
      std::filesystem::create_directories(options.out_dir / "films");
      film::FilmOptions o;
      o.config_dir = paths::config_dir();
      o.strip = options.out_dir / f.file;
      o.allow_drift = true;
      const auto made = film::film(row->evidence_path, o);
      if (!made.replay_identical)
        f.note = "recorded by another build or θ: the frames after step " +
                 (made.diverged_at ? std::to_string(*made.diverged_at) : std::string("0")) + " show the replay";
    } catch (const std::exception& e) {
      f.file.clear();
      f.note = std::string("no filmstrip: ") + e.what();
    }
    options.films.push_back(std::move(f));
  }
  const auto files = report::render(sources, options);
  if (a.json) {
    std::cout << report::summarize(sources, options).dump() << "\n";
    return 0;
  }
  std::cout << "report " << files.markdown.string() << "\n       " << files.html.string() << "\n";
  if (files.plots_skipped) std::cout << "plots skipped: " << files.plots_note << "\n";
  for (const auto& p : files.plots) std::cout << "plot   " << p.string() << "\n";
  return 0;
}

int cmd_stats_wilson(unsigned k, unsigned n, bool json) {
  const auto w = stats::wilson(k, n);
  if (json) {
    nlohmann::json j{{"k", k}, {"n", n}, {"wilson_lo", w.lo}, {"wilson_hi", w.hi}, {"z", stats::kZ95}};
    j["rate"] = n ? nlohmann::json(w.point) : nlohmann::json(nullptr);
    std::cout << j.dump() << "\n";
  } else {
    std::cout << std::setprecision(6) << k << "/" << n << "  rate " << w.point << "  Wilson 95% [" << w.lo << ", "
              << w.hi << "]\n";
  }
  return 0;
}

int cmd_stats_sign(unsigned wins, unsigned losses, bool json) {
  const double p = stats::sign_test_p(wins, losses);
  if (json) {
    std::cout << nlohmann::json{{"wins", wins}, {"losses", losses}, {"p", p}, {"test", "exact two-sided sign test"}}.dump()
              << "\n";
  } else {
    std::cout << std::setprecision(6) << "W/L " << wins << "/" << losses << "  exact two-sided sign test p = " << p << "\n";
  }
  return 0;
}

namespace {

std::vector<double> numbers(const std::string& list, const char* what) {
  if (list.empty() || list.back() == ',')
    throw std::invalid_argument(std::string(what) + ": '" + list + "' ends without a number (give a comma-separated list)");
  std::vector<double> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size())
      throw std::invalid_argument(std::string(what) + ": '" + item + "' is not a number (give a comma-separated list)");
    out.push_back(v);
  }
  return out;
}

}  // namespace

int cmd_stats_spearman(const std::string& xs, const std::string& ys, bool json) {
  const std::vector<double> x = numbers(xs, "X"), y = numbers(ys, "Y");
  const double rho = stats::spearman(x, y);
  if (json)
    std::cout << nlohmann::json{{"rho", rho}, {"n", x.size()}, {"test", "Spearman rank correlation, ties at mean rank"}}.dump()
              << "\n";
  else
    std::cout << std::setprecision(6) << "Spearman rho = " << rho << " over " << x.size() << " pairs\n";
  return 0;
}

int cmd_seeds(unsigned count, std::uint64_t salt, bool json) {
  const auto seeds = campaign::fresh_seed_block(count, salt);
  if (json) {
    std::cout << nlohmann::json{{"salt", salt}, {"seeds", seeds}}.dump() << "\n";
  } else {
    for (std::size_t i = 0; i < seeds.size(); ++i) std::cout << (i ? "," : "") << seeds[i];
    std::cout << "\n";
  }
  return 0;
}

}  // namespace dh::cli
