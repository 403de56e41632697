// `dh transfer`: frozen snapshots on new states (issue 16). Each snapshot's development success is read
// from a campaign database of its library (--dev-dbs: a climb's round databases), or measured on
// --dev-seeds when none holds it; each is then run on a fresh block (--fresh-seeds N --salt S, a salt
// nobody tuned on). The report sets the two columns side by side with Spearman ρ of their ranks and the
// first-to-last gain on each. Every campaign resumes from its database: a rerun runs no episode twice.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/cap/library_theta.hpp"
#include "dh/common/paths.hpp"
#include "dh/evo/transfer.hpp"
#include "dh/sim/scene.hpp"

namespace dh::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// Which rows count: the arm's, on the cells and (when given) the tasks asked for.
struct Selection {
  std::string arm;
  std::vector<std::string> cells;
  std::vector<unsigned> tasks;  ///< empty: every task
  std::vector<EpisodeRecord> rows_of(const fs::path& db) const {
    std::vector<EpisodeRecord> out;
    for (auto& r : campaign::CampaignDb::read_rows(db))
      if (r.arm == arm && std::find(cells.begin(), cells.end(), r.cell) != cells.end() &&
          (tasks.empty() || std::find(tasks.begin(), tasks.end(), r.task) != tasks.end()))
        out.push_back(std::move(r));
    return out;
  }
};

/// The first database of `dbs` whose campaign ran library `version` on `robot` with rows of the selection,
/// and those rows; nullopt when none.
std::optional<std::pair<fs::path, std::vector<EpisodeRecord>>> dev_rows_of(const std::vector<std::string>& dbs,
                                                                           const std::string& version,
                                                                           const std::string& robot,
                                                                           const Selection& sel) {
  for (const auto& f : dbs) {
    if (!fs::exists(f)) throw std::invalid_argument("--dev-dbs: no database " + f);
    const auto plan = campaign::CampaignDb::open(f).plan();
    if (!plan || plan->library_version != version || plan->robot != robot) continue;
    if (auto rows = sel.rows_of(f); !rows.empty()) return std::make_pair(fs::path(f), std::move(rows));
  }
  return std::nullopt;
}

}  // namespace

int cmd_transfer(const TransferArgs& a) {
  const auto snapshots = campaign::parse_list(a.snapshots, "--snapshots");
  if (snapshots.size() < 2)
    throw std::invalid_argument("--snapshots: give at least two library folders, in the climb's order");
  if (!a.robot.empty()) sim::robot_profile(a.robot);
  const Selection sel{
      a.arm, campaign::parse_list(a.cells, "--cells"),
      a.tasks.empty() ? std::vector<unsigned>{} : campaign::parse_numbers(a.tasks, "--tasks")};
  const auto dev_dbs =
      a.dev_dbs.empty() ? std::vector<std::string>{} : campaign::parse_list(a.dev_dbs, "--dev-dbs");
  const fs::path out = a.out.empty() ? paths::runs_dir() / "transfer" : fs::path(a.out);
  fs::create_directories(out);
  std::vector<evo::SnapshotEpisodes> all;
  for (const auto& dir : snapshots) {
    if (!fs::is_directory(dir)) throw std::invalid_argument("--snapshots: no library folder " + dir);
    const std::string version = cap::load_library_theta(dir).version;
    evo::SnapshotEpisodes s{dir, version, {}, {}};
    CampaignArgs c;
    c.arms = a.arm;
    c.cells = a.cells;
    c.tasks = a.tasks;
    c.library = dir;
    c.launch_file = a.launch_file;
    c.ready_ms = a.ready_ms;
    c.robot = a.robot;
    auto run = [&](const fs::path& db, const std::string& what) {
      c.db = db.string();
      std::cerr << "dh transfer: " << dir << " (" << version << "): " << what << "\n";
      const auto summary = run_campaign(c);
      return summary && !(*summary)["campaign"]["interrupted"].get<bool>();
    };
    if (auto found = dev_rows_of(dev_dbs, version, a.robot, sel)) {
      std::cerr << "dh transfer: " << dir << " (" << version << "): development success from "
                << found->first.string() << "\n";
      s.dev = std::move(found->second);
    } else {
      c.seeds = a.dev_seeds;
      if (!run(out / "dev" / (version + ".db"), "the development seeds " + a.dev_seeds)) return 1;
      s.dev = sel.rows_of(out / "dev" / (version + ".db"));
    }
    c.seeds.clear();
    c.fresh_seeds = a.fresh_seeds;
    c.salt = a.salt;
    const fs::path fresh = out / ("fresh-salt" + std::to_string(a.salt)) / (version + ".db");
    if (!run(fresh,
             "a fresh block, " + std::to_string(a.fresh_seeds) + " seeds, salt " + std::to_string(a.salt)))
      return 1;
    s.fresh = sel.rows_of(fresh);
    all.push_back(std::move(s));
  }
  const evo::TransferSummary summary = evo::summarise_transfer(all);
  const std::string md = "# Snapshots on new states\n\nArm " + a.arm + ", cells " + a.cells +
                         ", fresh block " + std::to_string(a.fresh_seeds) + " seeds per task, salt " +
                         std::to_string(a.salt) + ".\n\n" + evo::transfer_markdown(summary);
  std::ofstream(out / "transfer.md") << md;
  if (!a.json) {
    std::cout << md << "\nWritten to " << (out / "transfer.md").string() << "\n";
    return 0;
  }
  json rows = json::array();
  for (const auto& r : summary.snapshots)
    rows.push_back({{"snapshot", r.name},
                    {"version", r.version},
                    {"dev_success", r.dev.interval.point},
                    {"dev_episodes", r.dev_episodes},
                    {"fresh_success", r.fresh.interval.point},
                    {"fresh_episodes", r.fresh_episodes}});
  json paired;
  if (const auto& p = summary.fresh_paired)
    paired = {{"pairs", p->n},
              {"won", p->wins_a},
              {"lost", p->wins_b},
              {"diff", p->diff},
              {"bootstrap_lo", p->bootstrap.lo},
              {"bootstrap_hi", p->bootstrap.hi},
              {"clusters", p->clusters},
              {"sign_p", p->p}};
  std::cout << json{{"snapshots", rows},
                    {"rho", summary.rho ? json(*summary.rho) : json()},
                    {"dev_gain_pp", summary.dev_gain_pp},
                    {"fresh_gain_pp", summary.fresh_gain_pp},
                    {"fresh_paired", paired}}
                   .dump()
            << "\n";
  return 0;
}

}  // namespace dh::cli
