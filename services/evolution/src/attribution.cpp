#include "dh/evo/attribution.hpp"

#include <algorithm>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>

#include "dh/common/config.hpp"
#include "dh/common/digest.hpp"


#include <cstdio>

namespace dh::evo {

namespace {

using Check = std::function<bool(const EpisodeFacts&)>;

bool any_wait(const EpisodeFacts& f, std::initializer_list<const char*> waits) {
  return std::any_of(f.missed_waits.begin(), f.missed_waits.end(), [&](const std::string& w) {
    return std::any_of(waits.begin(), waits.end(), [&](const char* x) { return w == x; });
  });
}

bool any_refusal(const EpisodeFacts& f, std::initializer_list<Refusal> codes) {
  return std::any_of(f.refusals.begin(), f.refusals.end(), [&](const RefusalFacts& r) {
    return std::find(codes.begin(), codes.end(), r.code) != codes.end();
  });
}

/// A step was refused because its capability had no live instance, and that capability is one the
/// episode started without.
bool needed_missing(const EpisodeFacts& f) {
  return std::any_of(f.refusals.begin(), f.refusals.end(), [&](const RefusalFacts& r) {
    return (r.code == Refusal::UnknownCapability || r.code == Refusal::CapabilityNotAlive) &&
           std::find(f.missing.begin(), f.missing.end(), r.capability) != f.missing.end();
  });
}

bool any_command(const EpisodeFacts& f, const std::function<bool(const CommandFacts&)>& pred) {
  return std::any_of(f.commands.begin(), f.commands.end(), pred);
}

/// A completed step whose capability and arguments were dispatched again later: its effect did not hold.
bool completed_then_again(const EpisodeFacts& f) {
  for (std::size_t i = 0; i < f.commands.size(); ++i) {
    const CommandFacts& c = f.commands[i];
    if (c.recovery || c.state != "completed") continue;
    for (std::size_t j = i + 1; j < f.commands.size(); ++j)
      if (f.commands[j].capability == c.capability && f.commands[j].args == c.args) return true;
  }
  return false;
}

/// Command i was refused and a later command ran (a substitute, a replanned step): the harness went round
/// the refusal (Figure 3's refused push), so the failure does not sit there.
bool refusal_gone_round(const EpisodeFacts& f, std::size_t i) {
  return f.commands[i].state == "refused" &&
         std::any_of(f.commands.begin() + static_cast<std::ptrdiff_t>(i) + 1, f.commands.end(),
                     [](const CommandFacts& c) { return c.state != "refused"; });
}

struct NamedCheck {
  const char* name;
  const char* what;
  Check check;
};

const std::vector<NamedCheck>& checks() {
  static const std::vector<NamedCheck> all{
      {"infrastructure_loss", "flagged lost to infrastructure, or ended infrastructure or rejected",
       [](const EpisodeFacts& f) { return f.infrastructure || f.outcome == "infrastructure" || f.outcome == "rejected"; }},
      {"no_end", "the evidence has no episode_end record",
       [](const EpisodeFacts& f) { return !f.ended; }},
      {"process_lost", "an instance it dispatched to lost its liveliness",
       [](const EpisodeFacts& f) { return f.capability_lost; }},
      {"capability_missing", "it started without an instance of a capability, and a step needed that one",
       needed_missing},
      {"observation_missing", "the first or the next observation did not come in time",
       [](const EpisodeFacts& f) { return any_wait(f, {"first_observation", "observation"}); }},
      {"scene_stale", "no fresh scene estimate in time, or an argument's entity unseen (perception refusal)",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::Perception}); }},
      {"planner_silent", "the planner did not answer in time",
       [](const EpisodeFacts& f) { return any_wait(f, {"planner"}); }},
      {"planner_unreachable", "the planner's model server could not be asked (no key, no connection, no reply, HTTP error)",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::PlannerUnavailable}); }},
      {"planner_malformed", "the planner's reply could not be read as an advisory (not JSON, the schema broken)",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::PlannerMalformed}); }},
      {"planner_refused", "the planner refused to give a step",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::PlannerRefused}); }},
      {"ineligible_step", "a step names an unknown or masked capability, or arguments that do not resolve",
       [](const EpisodeFacts& f) {
         return any_refusal(f, {Refusal::UnknownCapability, Refusal::CapabilityMasked,
                                Refusal::MissingArgument, Refusal::UnresolvedEntity});
       }},
      {"grounding_refused", "a step's precondition did not hold at grounding",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::Precondition}); }},
      // The remaining budget could not pay for a step: a consequence of what spent it, so it sits with the
      // budget, downstream of a failure that made the steps run out.
      {"budget_refused", "the remaining steps could not pay for a step's cost at grounding",
       [](const EpisodeFacts& f) { return any_refusal(f, {Refusal::Budget}); }},
      {"dispatch_failed", "no live instance, or no acknowledgement of a dispatched command",
       [](const EpisodeFacts& f) { return any_wait(f, {"acknowledgement"}) || any_refusal(f, {Refusal::CapabilityNotAlive}); }},
      {"capability_refused", "a capability refused a command at its check, and no command ran after it",
       [](const EpisodeFacts& f) {
         for (std::size_t i = 0; i < f.commands.size(); ++i)
           if (f.commands[i].state == "refused" && !refusal_gone_round(f, i)) return true;
         return false;
       }},
      {"execution_failed", "a step's command failed with a typed failure, or spent its command budget unfinished",
       [](const EpisodeFacts& f) {
         return any_command(f, [](const CommandFacts& c) {
           return !c.recovery && (c.state == "failed" || c.state == "expired");
         });
       }},
      {"effect_absent",
       "a step completed but its effect did not hold (asked again, or the plan done or a frozen plan run to its "
       "end, and the goal unmet)",
       [](const EpisodeFacts& f) { return completed_then_again(f) || f.planner_done || f.gave_up_on_completion; }},
      {"recovery_failed", "an inserted recovery did not complete",
       [](const EpisodeFacts& f) { return any_command(f, [](const CommandFacts& c) { return c.recovery && failed(c); }); }},
      {"policy_in_control", "vla_act was the command in control at the end",
       [](const EpisodeFacts& f) { return !f.commands.empty() && f.commands.back().capability == "vla_act"; }},
      {"budget_while_progressing", "the budget ran out while the last decision saw progress",
       [](const EpisodeFacts& f) { return f.outcome == "budget_exhausted" && f.last_stagnant == 0; }},
      {"verdict_lost", "the task predicate held and was lost, or the latch and the end disagree",
       [](const EpisodeFacts& f) { return f.verdict_lost || (f.latched && !f.success); }},
  };
  return all;
}

const NamedCheck* find_check(const std::string& name) {
  for (const auto& c : checks())
    if (name == c.name) return &c;
  return nullptr;
}

/// The command the failure sits on: the first that failed (a refusal the harness went round aside), else
/// the last one dispatched.
Signature signature_of(const EpisodeFacts& f) {
  Signature s;
  const CommandFacts* c = f.commands.empty() ? nullptr : &f.commands.back();
  for (std::size_t i = 0; i < f.commands.size(); ++i)
    if (failed(f.commands[i]) && !refusal_gone_round(f, i)) {
      c = &f.commands[i];
      break;
    }
  if (c) {
    s.capability = c->capability;
    s.failure = c->failure != "none" ? c->failure : c->state;
    s.stage = c->stage;
    s.step = c->end_step ? c->end_step : c->dispatch_step;
  } else {
    s.failure = !f.refusals.empty() ? to_string(f.refusals.back().code)
                                    : (!f.missed_waits.empty() ? f.missed_waits.back() : f.outcome);
    s.step = f.steps;
  }
  return s;
}

}  // namespace

const std::vector<std::pair<std::string, std::string>>& check_names() {
  static const auto names = [] {
    std::vector<std::pair<std::string, std::string>> n;
    for (const auto& c : checks()) n.emplace_back(c.name, c.what);
    return n;
  }();
  return names;
}

std::string config_version(const AttributionConfig& config) {
  // The checks' own version: a change to what a check looks for changes every file's hash, so labels
  // made by the old checks are not read as the new ones'.
  std::string text = "checks-4\n";
  for (const Layer& l : config.layers) {
    text += l.name + (l.harness ? ":harness:" : ":other:");
    for (const auto& c : l.checks) text += c + ",";
    text += "\n";
  }
  return "attr-" + sha256_hex(text).substr(0, 16);
}

bool check(const std::string& name, const EpisodeFacts& facts) {
  const NamedCheck* c = find_check(name);
  if (!c) throw std::invalid_argument("no attribution check '" + name + "'");
  return c->check(facts);
}

AttributionConfig load_attribution(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  AttributionConfig config;
  std::set<std::string> names;
  for (const ConfigNode& n : root.items("layers")) {
    Layer l;
    l.name = n.get<std::string>("name");
    l.harness = n.get<bool>("harness");
    l.checks = n.get<std::vector<std::string>>("checks");
    if (l.checks.empty()) n.fail("checks", "layer '" + l.name + "' names no check");
    for (const auto& c : l.checks)
      if (!find_check(c)) {
        std::string known;
        for (const auto& [name, what] : check_names()) known += (known.empty() ? "" : ", ") + name;
        n.fail("checks", "no check '" + c + "' (known: " + known + ")");
      }
    if (!names.insert(l.name).second) n.fail("name", "layer '" + l.name + "' is named twice");
    config.layers.push_back(std::move(l));
  }
  if (config.layers.empty()) root.fail("layers", "no layers");
  return config;
}

std::optional<Attribution> attribute(const EpisodeFacts& facts, const AttributionConfig& config) {
  if (facts.ended && facts.success && !facts.infrastructure)
    throw std::invalid_argument("attribute: the episode succeeded; only failures are attributed");
  for (std::size_t j = 0; j < config.layers.size(); ++j) {
    const Layer& l = config.layers[j];
    if (std::any_of(l.checks.begin(), l.checks.end(), [&](const std::string& c) { return check(c, facts); }))
      return Attribution{static_cast<int>(j), l.name, l.harness, signature_of(facts)};
  }
  return std::nullopt;
}

}  // namespace dh::evo
