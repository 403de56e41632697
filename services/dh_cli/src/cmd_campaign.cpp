// dh campaign: arms × cells × tasks × seeds over every live simulator channel, one database row per
// finished episode, resumable: a rerun with the same --db runs only what is not recorded yet.
#include <unistd.h>

#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "client.hpp"
#include "commands.hpp"
#include "dh/campaign/db.hpp"
#include "dh/campaign/progress.hpp"
#include "dh/campaign/scheduler.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/clock.hpp"
#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/suite.hpp"
#include "dh/common/topics.hpp"
#include "dh/report/report.hpp"
#include "dh/sim/scene.hpp"

namespace dh::cli {

namespace {

using Clock = std::chrono::steady_clock;

std::string rerun_rule(unsigned reruns) {
  if (reruns == 0) return "none: an episode lost to infrastructure is recorded as a failure, flagged, and not rerun";
  return "infrastructure x" + std::to_string(reruns) +
         ": an episode lost to infrastructure (no result in time, its simulator worker lost, refused by the "
         "simulator or the governor) is run again, up to " + std::to_string(reruns) +
         " time(s); each lost attempt is kept in infrastructure_losses, the last attempt is the episode's row";
}

campaign::Plan make_plan(const CampaignArgs& a, const std::map<std::string, SuiteDef>& suites) {
  campaign::Plan plan;
  plan.arms = campaign::parse_list(a.arms, "--arms");
  const auto arms = load_arms(paths::config_dir() / "governor.yaml");
  for (const auto& arm : plan.arms) find_arm(arms, arm);
  plan.cells = campaign::parse_list(a.cells, "--cells");
  for (const auto& cell : plan.cells)
    if (!suites.count(cell)) find_task(suites, cell, 0);  // throws, listing the cells that exist
  if (!a.tasks.empty()) plan.tasks = campaign::parse_numbers(a.tasks, "--tasks");
  if (a.fresh_seeds > 0 && !a.seeds.empty())
    throw campaign::PlanError("give either --seeds or --fresh-seeds, not both");
  if (a.fresh_seeds > 0) plan.seeds = campaign::fresh_seed_block(a.fresh_seeds, a.salt);
  else if (!a.seeds.empty()) plan.seeds = campaign::parse_seeds(a.seeds);
  else throw campaign::PlanError("--seeds: missing (e.g. --seeds 1-20, or --fresh-seeds 20 --salt 7)");
  plan.rerun_rule = rerun_rule(a.reruns);
  return plan;
}

void print_summary(const nlohmann::json& s) {
  std::cout << std::fixed << std::setprecision(1);
  for (const auto& row : s["summary"]) {
    std::cout << "  " << row["arm"].get<std::string>() << "  " << row["cell"].get<std::string>() << "  "
              << row["successes"] << "/" << row["episodes"];
    if (!row["rate"].is_null()) {
      std::cout << "  " << 100.0 * row["rate"].get<double>() << "% (Wilson 95% " << 100.0 * row["wilson_lo"].get<double>()
                << "-" << 100.0 * row["wilson_hi"].get<double>();
      if (!row["cluster_lo"].is_null())
        std::cout << "; over " << row["clusters"] << " cell/task clusters " << 100.0 * row["cluster_lo"].get<double>()
                  << "-" << 100.0 * row["cluster_hi"].get<double>();
      std::cout << ")";
    }
    std::cout << "  infrastructure " << row["infrastructure"] << "\n";
  }
  for (const auto& total : s["arm_totals"])
    for (const auto& [capability, n] : total["ran_without"].items())
      std::cout << "  warning: " << total["arm"].get<std::string>() << " ran without " << capability << " in "
                << n << " of " << total["episodes"] << " episodes (no live instance when they started)\n";
}

}  // namespace

std::optional<nlohmann::json> run_campaign(const CampaignArgs& a) {
  install_shutdown_handlers();
  const auto suites = load_suites(paths::config_dir());
  const cap::LibraryTheta library =
      cap::load_library_theta(a.library.empty() ? paths::config_dir() / "library" : std::filesystem::path(a.library));
  campaign::Plan plan = make_plan(a, suites);
  plan.library_version = library.version;
  plan.planner_errors = a.planner_errors;
  plan.verifier = a.verifier;
  plan.robot = a.robot;
  if (!plan.robot.empty()) sim::robot_profile(plan.robot);  // an unknown robot is named before anything runs
  const msg::Verifier verifier = convert::to_msg(parse_verifier(a.verifier));
  const msg::PlannerErrorRates errors = convert::to_msg(planner_errors(a.planner_errors));
  const auto settings = arm_settings(paths::config_dir(), plan.arms);
  if (a.db.empty()) throw campaign::PlanError("--db: missing (the campaign database file, e.g. runs/c1.db)");
  auto db = campaign::CampaignDb::open(a.db);
  const auto differences = db.declare_plan(plan);
  if (!differences.empty()) {
    std::string why;
    for (const auto& d : differences) why += "\n  " + d;
    throw ConfigError(a.db + " holds another campaign:" + why + "\nresume it with its own plan or give another --db");
  }
  if (a.fresh_seeds > 0) db.set_meta("fresh_seed_salt", std::to_string(a.salt));
  db.set_meta("benchmark_note", report::kBenchmarkNote);

  const auto all = campaign::expand(plan, [&](const std::string& cell) {
    std::vector<unsigned> ids;
    for (const auto& [id, _] : suites.at(cell).tasks) ids.push_back(id);
    return ids;
  });
  const auto finished = db.finished();
  const auto todo = campaign::remaining(all, finished);
  std::size_t done_ok = 0, done_infra = 0;
  const std::set<campaign::EpisodeKey> planned(all.begin(), all.end());
  for (const auto& r : db.rows()) {
    if (!planned.count(campaign::key_of(r))) continue;
    done_ok += r.success && !r.infrastructure;
    done_infra += r.infrastructure;
  }
  const std::size_t done_before = all.size() - todo.size();
  if (!a.json)
    std::cerr << "campaign " << a.db << ": " << all.size() << " episodes (" << plan.arms.size() << " arms x "
              << plan.cells.size() << " cells x tasks x " << plan.seeds.size() << " seeds), " << done_before
              << " already recorded, " << todo.size() << " to run\n";

  std::size_t ran_now = 0, reran = 0;
  bool interrupted = false;
  double run_wall_s = 0;  // first request sent → last episode recorded, this run
  Clock::time_point last_run_record{};
  if (!todo.empty()) {
    dds::Participant participant("dh_campaign");
    Client client(participant);
    std::unique_ptr<Deployment> local;
    const std::string ready = ready_capability(campaign::parse_list(a.arms, "--arms"));
    if (!ensure_deployment(client, ready, std::nullopt, a.launch_file, std::chrono::milliseconds(a.ready_ms), a.json,
                           local))
      return std::nullopt;
    campaign::SchedulerOptions options;
    options.run_tag = run_tag();
    options.start_allowance = std::chrono::seconds(a.start_allowance_s);
    options.per_step_allowance = std::chrono::milliseconds(a.per_step_allowance_ms);
    options.reruns = a.reruns;
    campaign::Scheduler scheduler(todo, [&](const campaign::EpisodeKey& k) {
      return find_task(suites, k.cell, k.task).budget_steps;
    }, options);
    campaign::Progress progress(all.size(), done_before, done_ok, done_infra, Clock::now());
    std::map<std::pair<std::string, unsigned>, std::vector<msg::GoalTerm>> goals;  // by cell and task
    // Live views (dh view) follow the campaign on rt/dh/campaign/progress, tallied by arm and cell.
    dds::Writer<msg::CampaignProgressPubSubType> progress_topic(participant, topics::kCampaignProgress, dds::Qos::Episode);
    std::map<std::pair<std::string, std::string>, std::pair<unsigned, unsigned>> tally;  // -> (successes, episodes)
    for (const auto& arm : plan.arms)
      for (const auto& cell : plan.cells) tally[{arm, cell}];
    for (const auto& r : db.rows())
      if (planned.count(campaign::key_of(r))) {
        tally[{r.arm, r.cell}].first += r.success && !r.infrastructure;
        ++tally[{r.arm, r.cell}].second;
      }
    const auto publish = [&](Clock::time_point now, bool finished) {
      msg::CampaignProgress m;
      m.campaign(a.db);
      m.total(static_cast<std::uint32_t>(all.size()));
      m.done(static_cast<std::uint32_t>(progress.done()));
      m.successes(static_cast<std::uint32_t>(progress.successes()));
      m.infrastructure(static_cast<std::uint32_t>(progress.infrastructure()));
      m.reran(static_cast<std::uint32_t>(reran));
      m.rate_per_s(progress.rate_per_s(now).value_or(-1));
      m.eta_s(progress.eta_s(now).value_or(-1));
      m.finished(finished);
      for (const auto& [key, n] : tally) {
        msg::CellTally t;
        t.arm(key.first);
        t.cell(key.second);
        t.successes(n.first);
        t.episodes(n.second);
        m.cells().push_back(std::move(t));
      }
      progress_topic.write(m);
    };
    publish(Clock::now(), false);
    const bool terminal = isatty(STDERR_FILENO);
    auto last_print = Clock::now(), last_activity = Clock::now();
    std::optional<Clock::time_point> first_dispatch;
    std::set<std::pair<std::string, std::string>> warned;  // (arm, capability) said once on stderr
    auto record = [&](const std::vector<EpisodeRecord>& records) {
      bool any = false;
      for (const auto& rec : records)
        if (db.record(rec)) {
          for (const auto& c : rec.capabilities_missing.value_or(std::vector<std::string>{}))
            if (!a.json && warned.emplace(rec.arm, c).second)
              std::cerr << "\nwarning: arm " << rec.arm << " runs without " << c
                        << ": no live instance when episode " << rec.episode_id
                        << " started (the report counts every such episode)\n";
          progress.finished(rec.success && !rec.infrastructure, rec.infrastructure);
          tally[{rec.arm, rec.cell}].first += rec.success && !rec.infrastructure;
          ++tally[{rec.arm, rec.cell}].second;
          ++ran_now;
          any = true;
        }
      if (any) last_run_record = Clock::now();
      return any;
    };
    auto record_losses = [&] {
      for (const auto& rec : scheduler.take_losses()) {
        reran += db.record_loss(rec);
        if (!a.json) std::cerr << "\n" << rec.episode_id << " lost to infrastructure, runs again: " << rec.reason << "\n";
      }
    };
    while (!scheduler.done()) {
      const auto now = Clock::now();
      if (shutdown_requested()) {
        // Keep what finished; episodes still running are run again on resume.
        record(scheduler.take_finished(now + options.physics_wait));
        interrupted = true;
        break;
      }
      auto news = client.take_news();
      for (const auto& s : news.channels)
        scheduler.channel_status(s.channel(), s.worker(), s.state() == msg::CHANNEL_IDLE, s.last_episode_id(),
                                 s.last_physics_s(), s.last_error(), now, {s.last_goal_step(), s.last_goal_at_end()});
      for (const auto& r : news.results)
        scheduler.result({r.episode_id(), r.success(), r.steps(), convert::from_msg(r.outcome()), r.reason(),
                          r.evidence_path(), r.capabilities_missing()},
                         now);
      for (const auto& w : news.lost_workers) scheduler.worker_lost(w, now);
      for (const auto& w : news.returned_workers) scheduler.worker_back(w);
      if (!scheduler.conflict().empty()) throw std::runtime_error(scheduler.conflict());
      scheduler.expire(now);
      record_losses();
      // Another process writing this database may have recorded an episode meanwhile.
      const auto dispatches = scheduler.assign(now, [&](const campaign::EpisodeKey& k) {
        return db.has(k.arm, k.cell, k.task, k.seed);
      });
      if (!dispatches.empty() && !first_dispatch) first_dispatch = now;
      if (!dispatches.empty() || scheduler.running() > 0) last_activity = now;
      if (scheduler.pending() > 0 && now - last_activity > std::chrono::seconds(a.idle_abort_s)) {
        record(scheduler.take_finished(now + options.physics_wait));
        std::cerr << "\nerror: no simulator channel has been free for " << a.idle_abort_s
                  << " s (all busy elsewhere or lost); finished episodes are recorded, rerun to resume\n";
        interrupted = true;
        break;
      }
      for (const auto& d : dispatches) {
        const TaskDef& t = find_task(suites, d.key.cell, d.key.task);
        msg::EpisodeRequest r;
        r.channel(d.channel);
        r.episode_id(d.episode_id);
        r.suite(d.key.cell);
        r.task(d.key.task);
        r.seed(d.key.seed);
        r.cell(d.key.cell);
        r.arm(d.key.arm);
        r.instruction(instruction_for(t, d.key.seed));
        r.budget_steps(t.budget_steps);
        set_library(r, library);
        set_settings(r, settings.at(d.key.arm));
        r.planner_errors(errors);
        auto goal = goals.find({t.suite, t.id});
        if (goal == goals.end()) goal = goals.emplace(std::pair(t.suite, t.id), goal_terms(t)).first;
        r.goal(goal->second);
        r.verifier(verifier);
        r.robot(plan.robot);
        client.request(r);
      }
      const bool changed = record(scheduler.take_finished(now));
      if (changed || scheduler.done()) publish(now, scheduler.done());
      const bool due = terminal ? now - last_print > std::chrono::milliseconds(250)
                                : changed && (progress.done() % 10 == 0 || now - last_print > std::chrono::seconds(10));
      if (!a.json && (due || scheduler.done())) {
        std::cerr << progress.render(now, terminal);
        last_print = now;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!a.json && terminal) std::cerr << "\n";
    if (first_dispatch && last_run_record > *first_dispatch)
      run_wall_s = std::chrono::duration<double>(last_run_record - *first_dispatch).count();
  }

  nlohmann::json out = report::summarize({{a.db, db.rows()}}, report::ReportOptions{});
  out["campaign"] = {{"db", a.db},           {"episodes", all.size()},     {"recorded_before", done_before},
                     {"ran_now", ran_now},    {"remaining", all.size() - done_before - ran_now},
                     {"interrupted", interrupted}, {"rerun_rule", plan.rerun_rule}, {"library_version", plan.library_version}, {"planner_errors", plan.planner_errors}, {"robot", plan.robot}, {"reran", reran}, {"run_wall_s", run_wall_s}};
  return out;
}

int cmd_campaign(const CampaignArgs& a) {
  const auto out = run_campaign(a);
  if (!out) return 1;
  const nlohmann::json& c = (*out)["campaign"];
  const bool interrupted = c["interrupted"].get<bool>();
  if (a.json) {
    std::cout << out->dump() << "\n";
  } else {
    std::cout << (interrupted ? "campaign interrupted; rerun the same command to resume\n" : "campaign complete\n");
    print_summary(*out);
    if (const auto reran = c["reran"].get<std::size_t>(); reran > 0)
      std::cout << "  " << reran << " attempt(s) lost to infrastructure were run again (rule: "
                << c["rerun_rule"].get<std::string>() << ")\n";
    std::cout << "database " << a.db << "  (dh report --db " << a.db << ")\n";
  }
  return interrupted ? 1 : 0;
}

}  // namespace dh::cli
