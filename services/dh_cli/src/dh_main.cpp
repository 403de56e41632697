// dh: the user's command line.
//   dh tasks [--json]                        every cell's tasks with instruction, goal, budget
//   dh run --suite CELL --task N --seed K [--instruction TEXT]
//                                            one episode on a live deployment (starts deploy/local.yaml
//                                            when none answers); TEXT: the task's goal in your own words
//   dh campaign --arms A,B --cells C,D --seeds 21-40 --db FILE [--json]
//                                            arms x cells x tasks x seeds over every live channel; resumable
//   dh report --db FILE [--db FILE2] [--out DIR] [--json]
//   dh stats wilson K N | dh stats sign W L | dh stats spearman X1,X2,.. Y1,Y2,.. [--json]
//   dh seeds --fresh N --salt S              a fresh block of seeds nobody tuned on
//   dh swap CAPABILITY [--library FILE]      start a new instance, then drain and stop the old ones
//   dh train-policy [--config FILE]          demonstrations, then the embedded policy's weight file
//   dh replay EVIDENCE [--from-command K] [--library DIR] [--json] [--allow-drift]
//                                            re-runs a recorded episode in process and compares it step by
//                                            step (exit 0 identical, 3 diverged, 4 a fingerprint differs)
//   dh view [--port 8642] [--bind 127.0.0.1 --token T]
//                                            a web page: every channel live, campaigns' progress, episodes'
//                                            timelines and filmstrips (reads DDS; read-only)
//   dh film EVIDENCE --out F.png [--steps auto|S1,S2,..] [--camera agentview|wrist|workcell] [--video F.webm]
//                                            re-runs a recorded episode and renders the chosen steps into a
//                                            labelled strip (auto: refusals, recoveries, commands, verdict)
//   dh probe --evidence E --command K [--library DIR] [--rest [--rest-evidence F]] [--repeats R] [--json]
//                                            re-runs command K from the state recorded at its start under the
//                                            recorded θ or DIR's (exit 0 its effect held, 3 it did not);
//                                            --rest: and the rest of the episode after it
//   dh probe --db FILE --capability C [--library DIR] [--repeats R] [--jobs N] [--json]
//                                            the capability's probe set (its failed commands and as many
//                                            successes), probed in parallel
//   dh revise --db FILE [--capability C] [--library DIR] [--max-evals N] [--scan-levels L] [--screen N]
//             [--no-prune] [--out DIR]       searches C's θ within its ranges on its probe set (one parameter
//                                            at a time first, then the whole ranges when the parent holds
//                                            nothing; κ pruned); writes the
//                                            candidate library (exit 3: nothing better than the parent)
//   dh gate --parent DB --candidate DB --library DIR --capability C [--bare DB]
//                                            the paired gate (Eq. 6) of a candidate against its parent, on
//                                            the pairs where C's failures were attributed (exit 3: fails)
//   dh evolve --library DIR [--rounds K] [--cells ...] [--dev-seeds 21-40] [--regression-seeds 41-42]
//             [--out DIR]
//                                            the loop, automatic and resumable: campaign, revise, candidate
//                                            campaign, gate, broader round, register; per round
//   dh transfer --snapshots A,B,... --salt S [--fresh-seeds 20] [--dev-dbs F,...] [--out DIR]
//                                            frozen snapshots on a fresh block beside their development
//                                            success: Spearman ρ and the first-to-last gains
//   dh registry list | dh registry show ID   the candidates and the decisions on them
//   dh library perturb --from DIR --seed S --out DIR
//                                            every θ drawn uniformly within its range: an untuned library
//   dh attribute --db FILE [--config FILE] [--export F.jsonl] [--json] | dh attribute --checks
//                                            labels every failed episode with its attribution layer (exit 3:
//                                            one matched no layer or its evidence is unreadable)
//   dh launch [FILE] [--host H] [--restart]  runs a deployment (a multi-host file: host H's share) until
//                                            Ctrl-C
//   dh dds-profile FILE --host H             writes host H's DDS profile, prints its path
// Exit codes: 0 done (an episode that fails is a result), 1 infrastructure failure or interrupted
// campaign, 2 bad input (unknown cell/task/arm, bad config, malformed option, foreign database).
#include <CLI/CLI.hpp>

#include <iostream>

#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/common/config.hpp"
#include "dh/inproc/recording.hpp"

int main(int argc, char** argv) {
  using namespace dh::cli;
  CLI::App app{"dh: DynaHarness command line"};
  app.require_subcommand(1);
  bool json = false;
  auto* tasks = app.add_subcommand("tasks", "list every cell's tasks");
  tasks->add_flag("--json", json, "one JSON list on stdout");

  RunArgs run_args;
  auto* run = app.add_subcommand("run", "run one episode");
  run->add_option("--suite", run_args.suite, "cell name (see dh tasks): goal, goal-task, goal-swap, long, ...")->required();
  run->add_option("--task", run_args.task, "task number in the cell")->required();
  run->add_option("--seed", run_args.seed, "seed fixing the initial state (non-negative integer)")->required();
  run->add_option("--arm", run_args.arm, "executor configuration (configs/governor.yaml arms)");
  run->add_option("--channel", run_args.channel, "simulator channel to use (default: any idle one)");
  run->add_option("--timeout", run_args.timeout_s, "seconds to wait for the episode's result");
  run->add_option("--instruction", run_args.instruction,
                  "the instruction the planner is given instead of the task's (your own words for its goal; the "
                  "goal the episode is judged on stays the task's)");
  run->add_option("--ready-timeout-ms", run_args.ready_ms, "how long to look for a live deployment before starting one");
  run->add_option("--launch", run_args.launch_file, "launch file to start when no deployment answers");
  run->add_option("--library", run_args.library,
                  "capability library the episode runs (a folder of descriptors; default configs/library): its θ "
                  "travels in the request");
  run->add_option("--planner-errors", run_args.planner_errors,
                  "a profile of configs/planner_errors.yaml: the planner's advice is wrong on purpose at its rates");
  run->add_option("--verifier", run_args.verifier,
                  "the verdict the episode ends on: oracle (the simulator's) or perception (the goal judged on "
                  "perceived frames; needs an arm that grounds from perception)")
      ->check(CLI::IsMember({"oracle", "perception"}));
  run->add_option("--robot", run_args.robot,
                  "the arm on the scene's mount, a profile of configs/robots (panda, ur7e); default: the scene's own");
  run->add_flag("--json", run_args.json, "one JSON object on stdout");

  CampaignArgs camp;
  auto* campaign = app.add_subcommand("campaign", "run arms x cells x tasks x seeds into a campaign database");
  campaign->add_option("--arms", camp.arms, "comma-separated arms (configs/governor.yaml), default full");
  campaign->add_option("--cells", camp.cells, "comma-separated cells, e.g. goal-task,goal-swap,long-task,long-swap");
  campaign->add_option("--tasks", camp.tasks, "task numbers, e.g. 0-9 (default: every task of each cell)");
  campaign->add_option("--seeds", camp.seeds, "seeds, e.g. 1-20 or 1,3,5-7");
  campaign->add_option("--fresh-seeds", camp.fresh_seeds, "instead of --seeds: N fresh seeds (>= 1000000) from --salt");
  campaign->add_option("--salt", camp.salt, "salt of the fresh seed block (default 1)");
  campaign->add_option("--db", camp.db, "campaign database (SQLite); rerun with the same file to resume")->required();
  campaign->add_option("--launch", camp.launch_file, "launch file to start when no deployment answers");
  campaign->add_option("--planner-errors", camp.planner_errors,
                       "a profile of configs/planner_errors.yaml: every episode's planner errs on purpose at its "
                       "rates (a campaign of its own: the profile is part of its plan)");
  campaign->add_option("--verifier", camp.verifier,
                       "the verdict every episode ends on: oracle (the simulator's) or perception (the goal judged "
                       "on perceived frames; arms that ground from perception); part of the plan")
      ->check(CLI::IsMember({"oracle", "perception"}));
  campaign->add_option("--robot", camp.robot,
                       "the arm on every scene's mount, a profile of configs/robots (panda, ur7e); default: the "
                       "scenes' own; part of the plan");
  campaign->add_option("--library", camp.library,
                       "capability library every episode runs (a folder of descriptors; default configs/library): "
                       "its θ travels in each request, the running capability processes serve it");
  campaign->add_option("--ready-timeout-ms", camp.ready_ms, "how long to look for a live deployment before starting one");
  campaign->add_option("--start-allowance-s", camp.start_allowance_s,
                       "an episode is lost to infrastructure without a result after this + budget x per-step allowance");
  campaign->add_option("--per-step-allowance-ms", camp.per_step_allowance_ms, "wall time allowed per budget step");
  campaign->add_option("--idle-abort-s", camp.idle_abort_s,
                       "give up (resumable) when no channel has been free for this long with episodes pending");
  campaign->add_option("--reruns", camp.reruns,
                       "rerun rule, declared in the plan: run an episode lost to infrastructure again up to N times "
                       "(default 1; 0 records the loss as the episode's failure)");
  campaign->add_flag("--json", camp.json, "one JSON object on stdout (summary per arm and cell)");

  ReportArgs rep;
  bool no_plots = false;
  auto* report = app.add_subcommand("report", "render campaign databases as Markdown, HTML and PNG plots");
  report->add_option("--db", rep.dbs, "campaign database; repeat to pool several")->required();
  report->add_option("--out", rep.out, "output folder (default: <db>-report next to the first database)");
  report->add_option("--title", rep.title, "report title");
  report->add_option("--resamples", rep.resamples, "cell-bootstrap resamples (default 20000)");
  report->add_option("--bootstrap-seed", rep.bootstrap_seed, "seed of the cell bootstrap (default 20260926)");
  report->add_flag("--no-plots", no_plots, "skip the gnuplot PNGs");
  report->add_option("--policy", rep.policy_dir, "a dh train-policy output folder: describe the policy and its loss curve");
  report->add_option("--attribution", rep.attribution,
                     "attribution file whose labels (dh attribute --config) the failures-by-layer table shows "
                     "(default configs/attribution.yaml)");
  report->add_option("--films", rep.films,
                     "filmstrips in the report: auto (the paper's cases where the campaign has them: goal-swap 5, "
                     "a door episode, a long-horizon one), none, or ARM/CELL/TASK/SEED,... (default auto)");
  report->add_flag("--json", rep.json, "print the report's JSON object on stdout");

  auto* stats = app.add_subcommand("stats", "the report's statistics by hand");
  stats->require_subcommand(1);
  unsigned a = 0, b = 0;
  auto* wilson = stats->add_subcommand("wilson", "Wilson 95% interval of K successes in N");
  wilson->add_option("K", a, "successes")->required();
  wilson->add_option("N", b, "episodes")->required();
  wilson->add_flag("--json", json, "one JSON object on stdout");
  auto* sign = stats->add_subcommand("sign", "exact two-sided sign test of W exclusive wins against L");
  sign->add_option("W", a, "exclusive wins of the first arm")->required();
  sign->add_option("L", b, "exclusive wins of the second arm")->required();
  sign->add_flag("--json", json, "one JSON object on stdout");

  std::string xs, ys;
  auto* spearman = stats->add_subcommand("spearman", "Spearman rank correlation of paired lists (ties at mean rank)");
  spearman->add_option("X", xs, "comma-separated values, e.g. development success per snapshot")->required();
  spearman->add_option("Y", ys, "comma-separated values, as many, e.g. new-state success per snapshot")->required();
  spearman->add_flag("--json", json, "one JSON object on stdout");

  unsigned fresh = 0;
  std::uint64_t salt = 1;
  auto* seeds = app.add_subcommand("seeds", "print a fresh block of seeds for post-selection tests");
  seeds->add_option("--fresh", fresh, "how many seeds")->required();
  seeds->add_option("--salt", salt, "salt of the block (the same salt gives the same seeds)");
  seeds->add_flag("--json", json, "one JSON object on stdout");

  SwapArgs swap_args;
  auto* swap = app.add_subcommand("swap", "replace a capability process while episodes run");
  swap->add_option("capability", swap_args.capability, "capability name, e.g. pick_place")->required();
  swap->add_option("--exec", swap_args.exec, "executable of the new instance (default cap_<capability>)");
  swap->add_option("--library", swap_args.library, "descriptor YAML for the new instance (changed parameters)");
  swap->add_option("--wait-s", swap_args.wait_s, "how long the new instance has to announce itself");
  swap->add_option("--drain-wait-s", swap_args.drain_wait_s, "how long to wait for old instances to drain and exit");
  swap->add_flag("--json", swap_args.json, "one JSON object on stdout");

  TrainPolicyArgs train_args;
  auto* train = app.add_subcommand("train-policy", "collect demonstrations and train the embedded vla_act policy");
  train->add_option("--config", train_args.config, "policy YAML (default configs/policy.yaml)");
  train->add_option("--out", train_args.out, "weight file (default DH_RUNS_DIR/<output of the config>)");
  train->add_option("--seed", train_args.seed,
                    "seed of the training and of the demonstrations' action noise (default: the config's)");
  train->add_option("--epochs", train_args.epochs, "epochs (default: the config's)");
  train->add_flag("--reuse-demos", train_args.reuse_demos,
                  "train on the demonstrations saved beside the weight file (demos.bin) instead of collecting");
  train->add_option("--add-demos", train_args.add_demos, "also train on this demonstration file (repeatable)");

  std::string deploy, host;
  auto* launch = app.add_subcommand("launch", "run a deployment until Ctrl-C");
  launch->add_option("file", deploy, "launch YAML (default deploy/local.yaml)");
  launch->add_option("--host", host, "multi-host launch file: run this host's services with its DDS profile");
  bool restart = false;
  launch->add_flag("--restart", restart, "start a service again when it exits after running at least 5 s");
  bool list = false;
  launch->add_flag("--list", list, "print this host's services (name, executable, arguments) and exit");
  auto* profile = app.add_subcommand("dds-profile", "write a host's DDS profile of a multi-host launch file, print its path");
  profile->add_option("file", deploy, "multi-host launch YAML")->required();
  profile->add_option("--host", host, "host name in the file")->required();
  ReplayArgs replay_args;
  auto* replay = app.add_subcommand("replay", "re-run a recorded episode in process and compare it step by step");
  replay->add_option("evidence", replay_args.evidence, "the episode's evidence file (<episode>.jsonl; the seam's "
                                                       "<episode>.steps and .states beside it)")->required();
  replay->add_option("--from-command", replay_args.from_command,
                     "restore the state recorded at the K-th dispatched command's start (from 0) and replay "
                     "that command's actions");
  replay->add_option("--library", replay_args.library,
                     "the capability descriptors whose θ must match the recording (default configs/library)");
  replay->add_flag("--allow-drift", replay_args.allow_drift,
                   "replay even when the model, MuJoCo or θ differs from the recording, and say what differs");
  replay->add_flag("--json", replay_args.json,
                   "one JSON object: identical, steps, first_divergence {step, body, quantity} or null, ...");
  ViewArgs view_args;
  auto* view = app.add_subcommand("view", "a web page of every channel and campaign on the domain, live, and each "
                                          "episode's timeline and filmstrip");
  view->add_option("--port", view_args.port, "TCP port (default 8642; 0: any free one)");
  view->add_option("--bind", view_args.bind, "address to serve on (default 127.0.0.1: this host only)");
  view->add_option("--token", view_args.token, "a token every request must carry (?token=T): give one with --bind");
  view->add_option("--evidence-root", view_args.evidence_roots,
                   "another folder whose evidence files episode pages may read (the runs folder always)");
  view->add_option("--port-file", view_args.port_file, "write the port served on into this file");
  FilmArgs film_args;
  auto* film = app.add_subcommand("film", "re-run a recorded episode in process and render chosen steps into a "
                                          "labelled strip (PNG), or every step into a video");
  film->add_option("evidence", film_args.evidence, "the episode's evidence file (<episode>.jsonl; the seam's "
                                                   "<episode>.steps and .states beside it)")->required();
  film->add_option("--out", film_args.out, "the strip to write (.png)");
  film->add_option("--steps", film_args.steps,
                   "auto (refusals, recoveries, each command's start, middle and end, the verdict) or steps "
                   "S1,S2,... (default auto)");
  film->add_option("--max-frames", film_args.max_frames, "auto's limit (default 8)")->check(CLI::Range(1, 40));
  film->add_option("--camera", film_args.camera, "agentview, wrist or workcell (default agentview)");
  film->add_option("--width", film_args.width, "each frame's width in pixels (default 320)")->check(CLI::Range(16, 640));
  film->add_option("--height", film_args.height, "each frame's height in pixels (default 240)")->check(CLI::Range(16, 480));
  film->add_option("--video", film_args.video, "also every step as a video at 20 frames/s (.webm VP8 or .mp4)");
  film->add_option("--library", film_args.library,
                   "the capability descriptors whose θ must match the recording (default configs/library)");
  film->add_flag("--allow-drift", film_args.allow_drift, "film a recording of another build or θ, and say so");
  film->add_flag("--json", film_args.json, "one JSON object: the frames with their labels, the replay's identity");
  ProbeArgs probe_args;
  auto* probe = app.add_subcommand("probe", "re-run recorded commands from the state at their start: one (--evidence, "
                                            "--command) or a capability's probe set (--db, --capability)");
  probe->add_option("--evidence", probe_args.evidence, "the episode's evidence file (<episode>.jsonl; the seam's "
                                                       "<episode>.steps and .states beside it)");
  probe->add_option("--command", probe_args.command, "K: the K-th dispatched command (from 0)");
  probe->add_option("--db", probe_args.db, "a campaign database: probe the capability's probe set of its episodes");
  probe->add_option("--capability", probe_args.capability, "with --db: whose commands");
  probe->add_option("--arm", probe_args.arm, "with --db: the arm whose episodes (default full)");
  probe->add_option("--successes", probe_args.successes,
                    "with --db: successful commands kept beside the failing ones, at least (default 20)");
  probe->add_option("--draw-seed", probe_args.draw_seed, "with --db: seed of the draw of successes (default 0)");
  probe->add_option("--jobs", probe_args.jobs, "probes at once (default: every core)");
  probe
      ->add_option(
          "--repeats", probe_args.repeats,
          "run each probe R times, side by side, and say in how many it held and whether every run ended "
          "as the first, physics included (exit 4 when one did not; default 1)")
      ->check(CLI::Range(1u, 1000u));
  probe->add_option("--library", probe_args.library,
                    "a candidate library folder (descriptors as configs/library); default: the θ the episode recorded");
  probe->add_flag("--rest", probe_args.rest,
                  "run the rest of the episode after the command too, the governor restored from its snapshot at "
                  "its dispatch (one command: exit 0 the episode succeeded, 3 it did not; a set: judged by it)");
  probe->add_option("--rest-evidence", probe_args.rest_evidence,
                    "with --rest: where the resumed episode's evidence goes (default: a temporary file, removed)");
  probe->add_flag("--json", probe_args.json,
                  "one JSON object: state, failure, effect, effect_held, reproduces, first_divergence, rest, ... (a set: "
                  "failing, fixed, successes, kept, states)");
  ReviseArgs revise_args;
  auto* revise = app.add_subcommand("revise", "search a capability's θ within its ranges on its probe set");
  revise->add_option("--db", revise_args.db, "campaign database of the parent library")->required();
  revise->add_option("--capability", revise_args.capability,
                     "whose θ (default: the capability the most harness-attributed failures name)");
  revise->add_option("--arm", revise_args.arm, "the arm whose episodes (default full)");
  revise->add_option("--library", revise_args.library, "the parent library the campaign ran (default configs/library)");
  revise
      ->add_option("--max-evals", revise_args.max_evals,
                   "Subplex's candidate θ at most, its start included (the parent's is known from the set; "
                   "default 40)")
      ->check(CLI::Range(1u, 100000u));
  revise->add_option("--max-probes", revise_args.max_probes,
                     "probes at most over the search (each candidate probes the whole set; default no bound)");
  revise->add_option(
      "--scan-levels", revise_args.scan_levels,
      "when the set has failing states: levels of each parameter, moved alone across its range, "
      "probed on a few failing states before the search; it starts from the best when that holds "
      "more on the set than the parent (default 4; 0: no scan)");
  revise->add_option("--screen", revise_args.screen,
                     "when the parent holds nothing on the set: θ screened over the whole ranges (a Sobol sequence) "
                     "before the search starts from the best of them (default 64; 0: none)");
  revise
      ->add_option("--screen-states", revise_args.screen_states,
                   "failing states each scanned or screened θ is probed on (default 6)")
      ->check(CLI::Range(1u, 100000u));
  revise->add_flag("!--no-prune", revise_args.prune,
                   "keep every changed parameter (default: each goes back to the parent's value when the set "
                   "holds as many effects without it)");
  revise->add_option("--jobs", revise_args.jobs, "probes at once (default: every core)");
  revise->add_option("--successes", revise_args.successes, "successes in the probe set, at least (default 20)");
  revise->add_flag("--rest", revise_args.rest,
                   "judge the probe set by the rest of each episode run from its state (its success), not by the "
                   "command's effect");
  revise->add_option("--draw-seed", revise_args.draw_seed, "seed of the draw of successes (default 0)");
  revise->add_option("--out", revise_args.out, "folder for the candidate library (default runs/candidates/<version>)");
  revise->add_flag("--json", revise_args.json, "one JSON object: kappa, counts, evals, wall_s, out");
  GateArgs gate_args;
  auto* gate = app.add_subcommand("gate", "the paired gate (Eq. 6): a candidate library against its parent");
  gate->add_option("--parent", gate_args.parent, "campaign database of the parent library")->required();
  gate->add_option("--candidate", gate_args.candidate, "campaign database of the candidate, same cells, tasks and seeds")
      ->required();
  gate->add_option("--library", gate_args.library, "the candidate library folder (its episodes must have run it)")
      ->required();
  gate->add_option("--capability", gate_args.capability, "the revised capability: D holds the (cell, task) pairs "
                                                          "where the parent's failures were attributed to it")->required();
  gate->add_option("--bare", gate_args.bare, "campaign database of the bare arm on the same seeds (for D_π)");
  gate->add_option("--arm", gate_args.arm, "the arm compared (default full)");
  gate->add_option("--bare-arm", gate_args.bare_arm, "the bare arm's name in --bare (default bare)");
  gate->add_option("--config", gate_args.config, "attribution layers (default configs/attribution.yaml)");
  gate->add_option("--regression-parent", gate_args.regression_parent,
                   "the broader round: the parent's campaign over every cell on a separate block of seeds");
  gate->add_option("--regression-candidate", gate_args.regression_candidate,
                   "the broader round: the candidate's campaign on the same cells, tasks and seeds");
  gate->add_option("--tasks", gate_args.tasks,
                   "the tasks the broader round ran, e.g. 5 (default every task): it must cover every cell having them");
  gate->add_flag("--register", gate_args.register_decision,
                 "append the decision to the registry (admitted: passes the gate and the broader round)");
  gate->add_option("--registry", gate_args.registry, "registry folder (default $DH_RUNS_DIR/registry)");
  gate->add_flag("--json", gate_args.json, "one JSON object: pass, conditions, pairs, unpaired, contaminated");
  EvolveArgs evolve_args;
  auto* evolve = app.add_subcommand("evolve", "the self-evolution loop, round after round, resumable");
  evolve->add_option("--library", evolve_args.library, "the library the climb starts from")->required();
  evolve->add_option("--rounds", evolve_args.rounds, "rounds at most (default 3)");
  evolve->add_option("--cells", evolve_args.cells, "development cells (default goal-task,goal-swap,long-task,long-swap)");
  evolve->add_option("--tasks", evolve_args.tasks, "tasks (default all)");
  evolve->add_option("--dev-seeds", evolve_args.dev_seeds, "development seeds of every round's campaigns (default 21-40)");
  evolve->add_option("--regression-seeds", evolve_args.regression_seeds,
                     "the broader round's seeds, over every cell (default 41-42)");
  evolve->add_option("--arm", evolve_args.arm, "the arm that climbs (default full)");
  evolve->add_flag("!--no-bare", evolve_args.bare,
                   "skip the bare arm's campaign (the gate's third condition is then vacuous)");
  evolve->add_option("--max-evals", evolve_args.max_evals, "candidate θ probed at most per round (default 12)");
  evolve->add_option(
      "--scan-levels", evolve_args.scan_levels,
      "levels of each parameter in a round's one-at-a-time scan (dh revise --scan-levels; default 4)");
  evolve->add_option("--screen", evolve_args.screen,
                     "θ screened by a round's search whose parent holds nothing (dh revise --screen; default 64)");
  evolve->add_flag("!--no-prune", evolve_args.prune, "keep each round's κ unpruned (dh revise --no-prune)");
  evolve->add_option("--successes", evolve_args.successes, "successes in each probe set, at least (default 20)");
  evolve->add_flag("--rest", evolve_args.rest,
                   "the revision search judges its probe sets by the rest of each episode (dh revise --rest)");
  evolve->add_option("--out", evolve_args.out, "the climb's folder: state, campaigns, registry (default runs/evolve)");
  evolve->add_option("--launch", evolve_args.launch_file, "launch file for a local deployment when none is running");
  evolve->add_option("--ready-timeout-ms", evolve_args.ready_ms, "wait for a deployment (default 20000)");
  evolve->add_option("--robot", evolve_args.robot,
                     "the arm on every scene's mount in every campaign, a profile of configs/robots (default: the "
                     "scenes' own); part of the climb's plan");
  evolve->add_flag("--json", evolve_args.json, "one JSON object: start_success, final_success, rounds");
  TransferArgs transfer_args;
  auto* transfer = app.add_subcommand(
      "transfer", "frozen snapshots on a fresh block beside their development success: Spearman rho and the gains");
  transfer->add_option("--snapshots", transfer_args.snapshots, "library folders, in the climb's order (at least two)")
      ->required();
  transfer->add_option("--salt", transfer_args.salt, "the fresh block's salt: one never used in development")
      ->required();
  transfer->add_option("--fresh-seeds", transfer_args.fresh_seeds, "fresh seeds per task (default 20)");
  transfer->add_option("--dev-dbs", transfer_args.dev_dbs,
                       "campaign databases holding the snapshots' development success (a climb's round databases)");
  transfer->add_option("--dev-seeds", transfer_args.dev_seeds,
                       "a snapshot no --dev-dbs database ran is measured on these seeds (default 21-40)");
  transfer->add_option("--cells", transfer_args.cells, "cells (default goal-task,goal-swap,long-task,long-swap)");
  transfer->add_option("--tasks", transfer_args.tasks, "tasks (default all)");
  transfer->add_option("--arm", transfer_args.arm, "arm (default full)");
  transfer->add_option("--robot", transfer_args.robot,
                       "the arm on every scene's mount, a profile of configs/robots (default: the scenes' own)");
  transfer->add_option("--out", transfer_args.out, "folder of its databases and transfer.md (default runs/transfer)");
  transfer->add_option("--launch", transfer_args.launch_file, "launch file for a local deployment when none is running");
  transfer->add_option("--ready-timeout-ms", transfer_args.ready_ms, "wait for a deployment (default 20000)");
  transfer->add_flag("--json", transfer_args.json,
                     "one JSON object: snapshots, rho, dev_gain_pp, fresh_gain_pp, fresh_paired (the last "
                     "snapshot against the first, paired by seed)");
  std::string registry_dir, registry_id;
  auto* registry = app.add_subcommand("registry", "the candidates and the decisions on them");
  registry->require_subcommand(1);
  auto* registry_list = registry->add_subcommand("list", "every candidate, in order");
  registry_list->add_option("--registry", registry_dir, "registry folder (default $DH_RUNS_DIR/registry)");
  registry_list->add_flag("--json", json, "one JSON array of the entries");
  auto* registry_show = registry->add_subcommand("show", "one candidate's entry");
  registry_show->add_option("id", registry_id, "its id (r1, r2, ...)")->required();
  registry_show->add_option("--registry", registry_dir, "registry folder (default $DH_RUNS_DIR/registry)");
  auto* library = app.add_subcommand("library", "capability libraries");
  auto* perturb = library->add_subcommand("perturb", "draw every θ uniformly within its declared range");
  library->require_subcommand(1);
  std::string perturb_from, perturb_out;
  std::uint64_t perturb_seed = 0;
  perturb->add_option("--from", perturb_from, "library folder to start from (descriptors as configs/library)")->required();
  perturb->add_option("--seed", perturb_seed, "seed of the draw (the same seed draws the same θ)")->required();
  perturb->add_option("--out", perturb_out, "new or empty folder for the drawn library")->required();
  perturb->add_flag("--json", json, "one JSON object: version, theta by capability");
  AttributeArgs attr;
  auto* attribute = app.add_subcommand("attribute", "label every failed episode of a campaign database by layer");
  attribute->add_option("--db", attr.db, "campaign database");
  attribute->add_option("--config", attr.config, "attribution layers (default configs/attribution.yaml)");
  attribute->add_option("--export", attr.export_file, "write the experience (signature, label, outcome) as JSON lines");
  attribute->add_flag("--json", attr.json, "one JSON object: counts per layer, unmatched, u_d per arm and cell");
  attribute->add_flag("--checks", attr.list_checks, "list the checks a layer may name and exit");
  CLI11_PARSE(app, argc, argv);
  rep.plots = !no_plots;
  try {
    if (*tasks) return cmd_tasks(json);
    if (*run) return cmd_run(run_args);
    if (*campaign) return cmd_campaign(camp);
    if (*report) return cmd_report(rep);
    if (*wilson) return cmd_stats_wilson(a, b, json);
    if (*sign) return cmd_stats_sign(a, b, json);
    if (*spearman) return cmd_stats_spearman(xs, ys, json);
    if (*seeds) return cmd_seeds(fresh, salt, json);
    if (*swap) return cmd_swap(swap_args);
    if (*launch) return cmd_launch(deploy, host, restart, list);
    if (*profile) return cmd_dds_profile(deploy, host);
    if (*train) return cmd_train_policy(train_args);
    if (*replay) return cmd_replay(replay_args);
    if (*film) return cmd_film(film_args);
    if (*view) {
      if (view_args.bind != "127.0.0.1" && view_args.token.empty()) {
        std::cerr << "error: --bind " << view_args.bind << " opens the view to other hosts: give a --token too\n";
        return 2;
      }
      return cmd_view(view_args);
    }
    if (*attribute) return cmd_attribute(attr);
    if (*probe) return cmd_probe(probe_args);
    if (*revise) return cmd_revise(revise_args);
    if (*gate) return cmd_gate(gate_args);
    if (*evolve) return cmd_evolve(evolve_args);
    if (*transfer) return cmd_transfer(transfer_args);
    if (*registry_list) return cmd_registry(registry_dir, "", json);
    if (*registry_show) return cmd_registry(registry_dir, registry_id, true);
    if (*perturb) return cmd_library_perturb(perturb_from, perturb_seed, perturb_out, json);
  } catch (const dh::ConfigError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const dh::campaign::PlanError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const dh::campaign::CampaignError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const dh::inproc::EvidenceError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
