// `dh probe`: one recorded command, or a capability's probe set, re-run from the recorded states.
#include <fmt/format.h>

#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "dh/common/paths.hpp"
#include "dh/evo/probe.hpp"
#include "dh/evo/probe_set.hpp"
#include "evolution_inputs.hpp"

namespace dh::cli {

namespace {

std::string repeats_text(const evo::RepeatedProbe& r, unsigned repeats) {
  if (!r.error.empty()) return "a repeat could not run: " + r.error;
  return fmt::format("passed in {} of {} runs, {}", r.passed, repeats,
                     r.first_different
                         ? fmt::format("run {} ended otherwise than run 1", *r.first_different + 1)
                         : std::string("every run ended alike, physics included"));
}

nlohmann::json repeats_json(const evo::RepeatedProbe& r, unsigned repeats) {
  nlohmann::json j{{"runs", repeats},
                   {"passed", r.passed},
                   {"alike", r.alike()},
                   {"first_different", nullptr}};
  if (r.first_different) j["first_different"] = *r.first_different;
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

int probe_set(const ProbeArgs& a) {
  if (a.capability.empty()) throw std::invalid_argument("--db needs --capability (whose commands to probe)");
  const unsigned jobs = probe_jobs(a.jobs);
  const auto t0 = std::chrono::steady_clock::now();
  const evo::ProbeSet set = evo::probe_set(arm_rows(a.db, a.arm), {a.capability, a.successes, a.draw_seed, a.rest},
                                           paths::config_dir(), jobs);
  report_skipped(set);
  const auto& parent = set.states;
  if (parent.empty())
    throw std::invalid_argument(a.db + ": arm " + a.arm + " ran no command of '" + a.capability +
                                "' with evidence");
  std::vector<evo::ProbeState> states;
  for (const auto& p : parent) states.push_back(p.state);
  // Under a candidate library the set is probed again; without one, the parent's probes are the result.
  // Repeated, every state is probed again R times and the first run is the result.
  std::vector<evo::RepeatedProbe> repeated;
  std::vector<evo::ProbeOutcome> results;
  if (a.repeats > 1) {
    repeated = evo::probe_repeats(states, paths::config_dir(), a.library, a.repeats, jobs, a.rest);
    for (const auto& r : repeated) results.push_back(r.runs[0]);
  } else {
    results = a.library.empty()
                  ? parent
                  : evo::probe_states(states, paths::config_dir(), a.library, jobs, std::nullopt, a.rest);
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  unsigned failing = 0, fixed = 0, successes = 0, kept = 0, errors = 0, unalike = 0;
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t i = 0; i < results.size(); ++i) {
    const evo::ProbeOutcome& o = results[i];
    const bool held = o.report && o.report->passed();
    (o.state.failing ? failing : successes)++;
    (o.state.failing ? fixed : kept) += held;
    errors += !o.report;
    nlohmann::json j{{"label", o.state.label},
                     {"evidence", o.state.evidence},
                     {"command", o.state.command},
                     {"failing", o.state.failing},
                     {"effect_held", o.report && o.report->effect_held},
                     {"passed", held}};
    if (o.report) {
      if (o.report->rest) j["episode_success"] = o.report->rest->success;
      j["state"] = o.report->state;
      j["failure"] = o.report->failure;
      j["reproduces"] = o.report->reproduces;
    } else {
      j["error"] = o.error;
    }
    std::string runs;
    if (!repeated.empty()) {
      j["repeats"] = repeats_json(repeated[i], a.repeats);
      unalike += !repeated[i].alike();
      runs = "; " + repeats_text(repeated[i], a.repeats);
    }
    list.push_back(std::move(j));
    if (!a.json)
      std::cout << fmt::format(
          "{:<40} {:<8} {}{}\n", o.state.label, o.state.failing ? "failing" : "success",
          o.report
              ? o.report->state + (o.report->failure != "none" ? " " + o.report->failure : "") +
                    (o.report->effect_held ? ", effect held" : ", effect not held") +
                    (o.report->rest ? (o.report->rest->success ? ", episode won" : ", episode lost") : "")
              : "error: " + o.error,
          runs);
  }
  const std::string library = a.library.empty() ? "recorded" : a.library;
  if (a.json) {
    std::cout << nlohmann::json{{"capability", a.capability},
                                {"library", library},
                                {"rest", a.rest},
                                {"failing", failing},
                                {"fixed", fixed},
                                {"successes", successes},
                                {"kept", kept},
                                {"errors", errors},
                                {"jobs", jobs},
                                {"repeats", a.repeats},
                                {"unalike", unalike},
                                {"wall_s", wall_s},
                                {"states", list}}
                     .dump()
              << "\n";
  } else {
    std::cout << fmt::format(
        "{} under {}: {} failing state(s), {} in {}; {} success(es), still {} in {}; "
        "{} error(s); {:.1f} s on {} thread(s)\n",
        a.capability, library, failing, a.rest ? "the episode won" : "effect held", fixed, successes,
        a.rest ? "won" : "held", kept, errors, wall_s, jobs);
    if (a.repeats > 1)
      std::cout << fmt::format(
          "{} run(s) of each state: {} of {} state(s) ended otherwise than their first run\n", a.repeats,
          unalike, results.size());
  }
  return errors ? 2 : unalike ? 4 : 0;
}

}  // namespace

int cmd_probe(const ProbeArgs& a) {
  if (!a.db.empty()) return probe_set(a);
  if (a.evidence.empty() || !a.command)
    throw std::invalid_argument(
        "give --evidence FILE --command K (one command) or --db FILE --capability C (a probe set)");
  std::optional<evo::RepeatedProbe> repeated;
  evo::ProbeReport r;
  if (a.repeats > 1) {
    if (!a.rest_evidence.empty())
      throw std::invalid_argument("--rest-evidence keeps one run's evidence: give it without --repeats");
    repeated = evo::probe_repeats({{a.evidence, *a.command, false, a.evidence}}, paths::config_dir(),
                                  a.library, a.repeats, probe_jobs(a.jobs), a.rest)[0];
    if (!repeated->runs[0].report) {
      std::cerr << "error: " << repeated->runs[0].error << "\n";
      return 2;
    }
    r = *repeated->runs[0].report;
  } else {
    try {
      r = evo::probe(a.evidence,
                     {paths::config_dir(), a.library, *a.command, std::nullopt, a.rest, a.rest_evidence});
    } catch (const std::runtime_error& e) {
      std::cerr << "error: " << e.what() << "\n";
      return 2;
    }
  }
  const bool unalike = repeated && !repeated->alike();
  const int code = unalike ? 4 : (repeated ? repeated->passed == a.repeats : r.passed()) ? 0 : 3;
  if (a.json) {
    nlohmann::json j = evo::to_json(r);
    if (repeated) j["repeats"] = repeats_json(*repeated, a.repeats);
    std::cout << j.dump() << "\n";
    return code;
  }
  std::cout << r.episode_id << " command " << *a.command << " (" << r.command_id << ", " << r.capability
            << ") under " << (r.library == "recorded" ? "the recorded θ" : "library " + r.library)
            << ", from step " << r.from_step << ", budget " << r.budget_steps << " steps\n";
  std::cout << "  ended " << r.state << " at step " << r.end_step
            << (r.failure != "none" ? " (" + r.failure + (r.stage.empty() ? "" : " in " + r.stage) + ")" : "")
            << (r.reason.empty() ? "" : ": " + r.reason) << "\n";
  std::cout << "  effect " << r.effect << ": " << (r.effect_held ? "held" : "did not hold") << "\n";
  if (r.recorded)
    std::cout << "  recorded: " << r.recorded->state << " at step " << r.recorded->step
              << (r.recorded->failure != "none" ? " (" + r.recorded->failure + ")" : "") << "\n";
  else
    std::cout << "  recorded: the governor moved on before the command ended\n";
  std::cout << "  " << r.steps_compared << " step(s) compared with the step log: "
            << (r.first_divergence ? "first differs at step " + std::to_string(r.first_divergence->step) +
                                         ", " + r.first_divergence->body + " " + r.first_divergence->quantity
                                   : std::string("identical"))
            << (r.reproduces ? (r.rest ? "; the rest of the episode reproduced bit for bit"
                                       : "; the recorded command reproduced bit for bit")
                             : "")
            << "\n";
  if (r.rest) {
    std::cout << "  rest of the episode: " << r.rest->outcome << " at step " << r.rest->steps
              << (r.rest->reason.empty() ? "" : ": " + r.rest->reason) << "\n";
    if (r.rest->recorded)
      std::cout << "  recorded episode: " << r.rest->recorded->outcome << " at step " << r.rest->recorded->steps << "\n";
  }
  if (repeated) std::cout << "  repeats: " << repeats_text(*repeated, a.repeats) << "\n";
  return code;
}

}  // namespace dh::cli
