// dh attribute: labels every failed episode of a campaign database with its attribution layer and
// failure signature (services/evolution), stores them in the database under the attribution file's
// hash, and prints the counts per layer and arm and u_d (harness-attributed failures) per arm and cell.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/paths.hpp"
#include "dh/evo/attribution.hpp"

namespace dh::cli {

namespace {

using nlohmann::json;

std::string key_text(const EpisodeRecord& r) {
  return r.arm + " " + r.cell + "/" + std::to_string(r.task) + " seed " + std::to_string(r.seed);
}

}  // namespace

int cmd_attribute(const AttributeArgs& a) {
  if (a.list_checks) {
    for (const auto& [name, what] : evo::check_names()) std::cout << fmt::format("{:<26} {}\n", name, what);
    return 0;
  }
  const std::filesystem::path config_file =
      a.config.empty() ? paths::config_dir() / "attribution.yaml" : std::filesystem::path(a.config);
  const evo::AttributionConfig config = evo::load_attribution(config_file);
  const std::string version = evo::config_version(config);
  if (a.db.empty()) throw std::invalid_argument("--db: missing (the campaign database to attribute)");
  if (!std::filesystem::exists(a.db))
    throw campaign::CampaignError(a.db + ": no such campaign database (run dh campaign --db " + a.db + " first)");
  auto db = campaign::CampaignDb::open(a.db);
  std::ofstream experience;
  if (!a.export_file.empty()) {
    experience.open(a.export_file);
    if (!experience) throw std::runtime_error("cannot write --export " + a.export_file);
  }

  std::vector<std::string> arms;
  std::vector<std::map<std::string, unsigned>> by_layer(config.layers.size());  // layer -> arm -> count
  std::map<std::pair<std::string, std::string>, unsigned> harness_by_cell;      // (arm, cell) -> u_d
  std::vector<campaign::AttributionRow> labels;
  json unmatched = json::array(), unreadable = json::array();
  unsigned failed = 0;
  for (const EpisodeRecord& r : db.rows()) {
    harness_by_cell.try_emplace({r.arm, r.cell}, 0);  // every cell gets its u_d, 0 included
    if (r.success && !r.infrastructure) continue;
    ++failed;
    if (std::find(arms.begin(), arms.end(), r.arm) == arms.end()) arms.push_back(r.arm);
    const json key{{"arm", r.arm}, {"cell", r.cell}, {"task", r.task}, {"seed", r.seed}, {"evidence", r.evidence_path}};
    std::optional<evo::Attribution> label;
    try {
      std::vector<json> records;
      if (!r.evidence_path.empty() && std::filesystem::exists(r.evidence_path))
        records = read_evidence(r.evidence_path);
      else if (!r.infrastructure)
        throw std::runtime_error(r.evidence_path.empty() ? "the campaign recorded no evidence path for it"
                                                         : "its evidence file '" + r.evidence_path + "' is missing");
      label = evo::attribute(evo::read_facts(records, r.infrastructure), config);
    } catch (const std::exception& e) {  // a malformed record, evidence that says success: this episode only
      std::cerr << "error: " << key_text(r) << ": " << e.what() << "\n";
      json entry = key;
      entry["error"] = e.what();
      unreadable.push_back(std::move(entry));
      continue;
    }
    if (!label) {
      std::cerr << "error: " << key_text(r) << ": no layer of " << config_file.string() << " matches its evidence ("
                << r.evidence_path << "); see what each check looks for with `dh attribute --checks`, then add a "
                << "check or a layer\n";
      unmatched.push_back(key);
      continue;
    }
    const evo::Signature& xi = label->signature;
    labels.push_back({r.arm, r.cell, r.task, r.seed, version, label->layer, label->name, label->harness,
                      xi.capability, xi.failure, xi.stage, xi.step});
    ++by_layer[label->layer][r.arm];
    if (label->harness) ++harness_by_cell[{r.arm, r.cell}];
    if (experience)
      experience << json{{"key", key},
                         {"signature", {{"capability", xi.capability}, {"failure", xi.failure}, {"stage", xi.stage},
                                        {"step", xi.step}}},
                         {"label", {{"layer", label->layer}, {"name", label->name}, {"harness", label->harness}}},
                         {"outcome", r.outcome},
                         {"success", r.success && !r.infrastructure},
                         {"config", version}}
                        .dump()
                 << "\n";
  }

  db.replace_attributions(version, labels);

  json layers = json::array();
  for (std::size_t j = 0; j < config.layers.size(); ++j) {
    unsigned total = 0;
    for (const auto& [arm, n] : by_layer[j]) total += n;
    layers.push_back({{"layer", j}, {"name", config.layers[j].name}, {"harness", config.layers[j].harness},
                      {"count", total}, {"by_arm", by_layer[j]}});
  }
  json u_d = json::array();
  for (const auto& [arm_cell, n] : harness_by_cell) u_d.push_back({{"arm", arm_cell.first}, {"cell", arm_cell.second}, {"u_d", n}});
  if (a.json) {
    std::cout << json{{"config", version},    {"file", config_file.string()}, {"failed", failed},
                      {"layers", layers},     {"unmatched", unmatched.size()}, {"unmatched_episodes", unmatched},
                      {"unreadable", unreadable}, {"u_d", u_d}}
                     .dump()
              << "\n";
  } else {
    std::cout << fmt::format("{}: {} failed episode(s) attributed under {} ({})\n", a.db, failed, config_file.string(),
                             version);
    std::string header = fmt::format("{:<22} {:<8}", "layer", "harness");
    for (const auto& arm : arms) header += fmt::format(" {:>8}", arm);
    std::cout << header << "\n";
    for (std::size_t j = 0; j < config.layers.size(); ++j) {
      std::string line = fmt::format("{:<22} {:<8}", config.layers[j].name, config.layers[j].harness ? "yes" : "no");
      for (const auto& arm : arms) {
        const auto it = by_layer[j].find(arm);
        line += fmt::format(" {:>8}", it == by_layer[j].end() ? 0u : it->second);
      }
      std::cout << line << "\n";
    }
    std::cout << "unmatched: " << unmatched.size() << ", unreadable: " << unreadable.size() << "\n";
    for (const auto& [arm_cell, n] : harness_by_cell)
      std::cout << fmt::format("u_d {} {}: {}\n", arm_cell.first, arm_cell.second, n);
  }
  return unmatched.empty() && unreadable.empty() ? 0 : 3;
}

}  // namespace dh::cli
