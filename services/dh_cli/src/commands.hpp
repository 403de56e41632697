// The `dh` subcommands. Each returns the process exit code: 0 done (an episode's failure is a result,
// not an error), 1 infrastructure failure (no deployment, no result in time), 2 bad input.
#pragma once

#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace dh::cli {

int cmd_tasks(bool json);

struct ReplayArgs {
  std::string evidence, library;
  std::optional<std::uint32_t> from_command;
  bool allow_drift = false, json = false;
};
/// Exit codes of its own: 0 identical, 3 diverged, 4 refused (a fingerprint differs), 2 bad input.
int cmd_replay(const ReplayArgs& a);

struct ViewArgs {
  std::string bind = "127.0.0.1", token, port_file;
  std::uint16_t port = 8642;
  std::vector<std::string> evidence_roots;
};
/// Serves the live view until Ctrl-C: 0 stopped, 2 it cannot serve (the port is taken, a bad address).
int cmd_view(const ViewArgs& a);

struct FilmArgs {
  std::string evidence, steps = "auto", camera = "agentview", out, video, library;
  std::size_t max_frames = 8;
  int width = 320, height = 240;
  bool allow_drift = false, json = false;
};
/// 0 written, 2 bad input (a missing or corrupt recording, a step past the episode, an unknown camera),
/// 4 refused (the recording is of another build or θ; --allow-drift films it anyway), 1 nothing renders.
int cmd_film(const FilmArgs& a);

struct ProbeArgs {
  std::string evidence, library;
  std::optional<std::uint32_t> command;
  bool rest = false;          ///< and the rest of the episode after the command; a set is judged by it
  std::string rest_evidence;  ///< with rest, one command: where its evidence goes
  // A probe set instead of one command:
  std::string db, capability, arm = "full";
  std::size_t successes = 20;
  std::uint64_t draw_seed = 0;
  unsigned jobs = 0;  ///< 0: every core
  unsigned repeats = 1;  ///< runs of each probe, compared with the first
  bool json = false;
};
/// One command: exit 0 its effect held (with rest: the episode succeeded) in every run, 3 it did not. A
/// probe set: exit 0 when every state was probed. 2 bad input (a missing or corrupt recording or
/// database, a command out of range or one a probe cannot re-run, a library that does not load). 4 with
/// --repeats: a run did not end as the first did.
int cmd_probe(const ProbeArgs& a);

struct ReviseArgs {
  std::string db, capability, arm = "full", library, out;
  unsigned max_evals = 40, max_probes = 0, jobs = 0;
  unsigned scan_levels = 4;  ///< levels of each parameter in the one-at-a-time scan (0: none)
  unsigned screen = 64,
           screen_states =
               6;  ///< θ screened when the parent holds nothing; failing states scanned or screened on
  bool prune = true;                        ///< κ pruned after the search
  std::size_t successes = 20;
  std::uint64_t draw_seed = 0;
  bool rest = false;  ///< the probe set judged by the rest of each episode
  bool json = false;
};
/// `dh revise`: exit 0 with a candidate written to --out, 3 when no θ did better than the parent's.
int cmd_revise(const ReviseArgs& a);
/// No failure left to revise: exit 2 from `dh revise`, the end of the climb for `dh evolve`.
struct NothingToRevise : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};
/// The revision search of `dh revise`: with no --capability, the one the dominant attributed signature
/// names among those not in `excluded`. Returns what `dh revise --json` prints; with a candidate (exit 0)
/// "out" names its library folder, beside which revision.json records κ and the probes.
nlohmann::json revise_candidate(const ReviseArgs& a, const std::set<std::string>& excluded = {});

struct GateArgs {
  std::string parent, candidate, bare, capability, library, config, arm = "full", bare_arm = "bare";
  std::string regression_parent, regression_candidate;  ///< the broader round's two campaigns
  std::string tasks;  ///< the tasks the broader round ran ("" = every task): it covers the cells having them
  std::string registry;                                 ///< with register: the registry folder
  bool register_decision = false, json = false;
};
/// The broader round's cells: every cell `dh tasks` lists that has each of `tasks` (a --tasks list; all
/// cells when empty). The hw cells have four tasks, the others ten.
std::vector<std::string> broader_round_cells(const std::string& tasks);
/// `dh gate`: exit 0 the candidate passes Eq. 6's four conditions (and the broader regression, when
/// given), 3 it does not. With --register the decision goes to the registry.
int cmd_gate(const GateArgs& a);
/// The decision of `dh gate`, registered when asked: what `dh gate --json` prints.
nlohmann::json gate_decision(const GateArgs& a);
/// `dh registry list` (id empty) or `dh registry show ID`.
struct EvolveArgs {
  std::string library, out, launch_file, arm = "full";
  std::string cells = "goal-task,goal-swap,long-task,long-swap";  ///< the paper's four perturbed cells
  std::string tasks, dev_seeds = "21-40", regression_seeds = "41-42";
  unsigned rounds = 3, max_evals = 12, ready_ms = 20000;
  unsigned scan_levels =
      4;  ///< levels of each parameter in a round's one-at-a-time scan (dh revise --scan-levels)
  unsigned screen = 64;  ///< θ screened by a round's search whose parent holds nothing (dh revise --screen)
  bool prune = true;     ///< each round's κ pruned (dh revise --no-prune)
  std::size_t successes = 20;
  bool bare = true, json = false;
  bool rest = false;  ///< the revision search judges its probe sets by the rest of each episode
  std::string robot;  ///< the arm on every scene's mount in every campaign (a robot profile); empty: the scenes' own
};
/// The self-evolution loop, resumable: exit 1 when a campaign was interrupted or found no deployment.
int cmd_evolve(const EvolveArgs& a);

struct TransferArgs {
  std::string snapshots, dev_dbs, out, launch_file, arm = "full";
  std::string cells = "goal-task,goal-swap,long-task,long-swap";
  std::string tasks, dev_seeds = "21-40";
  std::string robot;  ///< the arm on every scene's mount (a robot profile); empty: the scenes' own
  unsigned fresh_seeds = 20;
  std::uint64_t salt = 0;
  unsigned ready_ms = 20000;
  bool json = false;
};
int cmd_transfer(const TransferArgs& a);

int cmd_registry(const std::string& dir, const std::string& id, bool json);

/// `dh library perturb`: writes `out`, prints the drawn library's version (or a JSON object with it and θ).
int cmd_library_perturb(const std::string& from, std::uint64_t seed, const std::string& out, bool json);

struct RunArgs {
  std::string suite, launch_file, library;
  std::string instruction;  ///< replaces the task's (a -lan cell's: the seed's wording) when not empty
  std::string planner_errors;  ///< a profile of configs/planner_errors.yaml; empty: none
  std::string verifier = "oracle";  ///< the verdict the episode ends on: oracle | perception
  std::string robot;  ///< the arm on the scene's mount (configs/robots/<robot>.yaml); empty: the scene's own
  unsigned task = 0, seed = 0, timeout_s = 180, ready_ms = 2500;
  std::string arm = "full";
  std::optional<std::uint32_t> channel;
  bool json = false;
};
int cmd_run(const RunArgs& a);

/// Runs a launch file's services (a multi-host file: those of `host`, with the host's DDS profile);
/// `restart`: a service that exits after running a while is started again; `list`: print the services
/// (name, executable, arguments; tab-separated) instead of running them.
int cmd_launch(const std::string& file, const std::string& host, bool restart, bool list);
/// Writes the DDS profile of `host` of a multi-host launch file and prints its path.
int cmd_dds_profile(const std::string& file, const std::string& host);

struct CampaignArgs {
  std::string arms = "full", cells = "goal", tasks, seeds, db, launch_file, library;
  std::string planner_errors;  ///< a profile of configs/planner_errors.yaml; empty: none
  std::string verifier = "oracle";  ///< the verdict every episode ends on: oracle | perception
  std::string robot;  ///< the arm on every scene's mount (configs/robots/<robot>.yaml); empty: the scenes' own
  unsigned fresh_seeds = 0;
  std::uint64_t salt = 1;
  unsigned ready_ms = 2500;
  unsigned start_allowance_s = 30;
  unsigned per_step_allowance_ms = 200;
  unsigned idle_abort_s = 120;
  unsigned reruns = 1;  ///< the rerun rule: attempts lost to infrastructure run again up to this often
  bool json = false;
};
int cmd_campaign(const CampaignArgs& a);
/// The campaign without its printed summary: the summary JSON with a "campaign" block (episodes, ran_now,
/// interrupted, ...); nullopt when no deployment answered (already reported on stderr).
std::optional<nlohmann::json> run_campaign(const CampaignArgs& a);

struct ReportArgs {
  std::vector<std::string> dbs;
  std::string out, title = "DynaHarness campaign report", policy_dir;
  std::string attribution;  ///< the attribution file whose labels the report shows (default configs/attribution.yaml)
  unsigned resamples = 20000;
  std::uint64_t bootstrap_seed = 20260926;
  bool plots = true, json = false;
  std::string films = "auto";  ///< auto, none, or ARM/CELL/TASK/SEED,...
};
int cmd_report(const ReportArgs& a);

struct SwapArgs {
  std::string capability, exec, library;
  unsigned wait_s = 20, drain_wait_s = 60, discovery_ms = 1500;
  bool json = false;
};
int cmd_swap(const SwapArgs& a);

struct TrainPolicyArgs {
  std::string config, out;
  std::optional<std::uint64_t> seed;
  std::optional<unsigned> epochs;
  bool reuse_demos = false;
  std::vector<std::string> add_demos;
};
int cmd_train_policy(const TrainPolicyArgs& a);

struct AttributeArgs {
  std::string db, config, export_file;
  bool json = false, list_checks = false;
};
/// Exit 0 when every failed episode is labelled, 3 when one matches no layer or its evidence is unreadable.
int cmd_attribute(const AttributeArgs& a);

int cmd_stats_wilson(unsigned k, unsigned n, bool json);
int cmd_stats_sign(unsigned wins, unsigned losses, bool json);
int cmd_stats_spearman(const std::string& x, const std::string& y, bool json);
int cmd_seeds(unsigned count, std::uint64_t salt, bool json);

}  // namespace dh::cli
