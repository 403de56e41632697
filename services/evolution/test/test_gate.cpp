// The paired gate (Eq. 6) on constructed counts: a candidate that passes, each condition failing alone,
// a vacuous bare-policy condition, an unpaired episode, and what makes an episode contaminated.
#include <gtest/gtest.h>

#include "dh/evo/gate.hpp"

using namespace dh;
using namespace dh::evo;

namespace {

// Outcomes by seed, one letter each: S success, H failure attributed to a harness layer, F another
// failure (policy-owned, infrastructure), X a contaminated success.
std::vector<GateEpisode> episodes(const std::string& cell, unsigned task, const std::string& outcomes) {
  std::vector<GateEpisode> v;
  for (unsigned seed = 0; seed < outcomes.size(); ++seed) {
    const char o = outcomes[seed];
    v.push_back({cell, task, seed + 1, o == 'S' || o == 'X', o == 'H', o == 'X'});
  }
  return v;
}

std::vector<GateEpisode> both(const std::string& swap5, const std::string& task1) {
  auto v = episodes("goal-swap", 5, swap5);
  for (auto& e : episodes("goal-task", 1, task1)) v.push_back(e);
  return v;
}

const std::set<CellTask> kD{{"goal-swap", 5}, {"goal-task", 1}};
// The bare arm wins goal-task/1 (3 of 4 seeds), not goal-swap/5.
const std::vector<GateEpisode> kBare = both("SFFF", "SSSF");
// Parent: goal-swap/5 2 successes, 1 harness failure, 1 other; goal-task/1 3 successes, 1 harness failure.
const std::vector<GateEpisode> kParent = both("SSHF", "SSSH");

const GateCondition& condition(const GateResult& g, const std::string& name) {
  for (const auto& c : g.conditions)
    if (c.name == name) return c;
  throw std::out_of_range(name);
}

void expect_only_failing(const GateResult& g, const std::string& failing) {
  EXPECT_FALSE(g.pass);
  for (const auto& c : g.conditions) EXPECT_EQ(c.pass, c.name != failing) << c.name << ": " << c.detail;
}

}  // namespace

TEST(PairedGate, ACandidateThatFixesAHarnessFailurePasses) {
  const auto g = paired_gate(kParent, both("SSSF", "SSSH"), kBare, kD);
  EXPECT_TRUE(g.pass);
  EXPECT_EQ(condition(g, "successes").candidate, 6);
  EXPECT_EQ(condition(g, "successes").parent, 5);
  EXPECT_EQ(condition(g, "harness_failures").candidate, 1);
  EXPECT_EQ(condition(g, "harness_failures").parent, 2);
  EXPECT_FALSE(g.pi_vacuous);
  EXPECT_TRUE(g.pairs.at({"goal-task", 1}).in_pi);
  EXPECT_FALSE(g.pairs.at({"goal-swap", 5}).in_pi);
  EXPECT_EQ(g.conditions.size(), 4u);
}

TEST(PairedGate, FewerSuccessesFailAlone) {
  // A success becomes a failure no harness layer owns: u does not rise, the bare arm's pair is untouched.
  expect_only_failing(paired_gate(kParent, both("SFHF", "SSSH"), kBare, kD), "successes");
}

TEST(PairedGate, MoreHarnessFailuresFailAlone) {
  // A failure no harness layer owned becomes a harness one: successes hold, u rises.
  expect_only_failing(paired_gate(kParent, both("SSHH", "SSSH"), kBare, kD), "harness_failures");
}

TEST(PairedGate, ALostSuccessWhereTheBarePolicyWinsFailsAlone) {
  // goal-task/1 (in D_π) loses a success to a non-harness failure; goal-swap/5 gains two: the sums improve.
  const auto g = paired_gate(kParent, both("SSSS", "SSFH"), kBare, kD);
  expect_only_failing(g, "bare_policy_pairs");
  EXPECT_NE(condition(g, "bare_policy_pairs").detail.find("goal-task/1 2 < 3"), std::string::npos)
      << condition(g, "bare_policy_pairs").detail;
}

TEST(PairedGate, AContaminatedEpisodeFailsAlone) {
  const auto g = paired_gate(kParent, both("SXHF", "SSSH"), kBare, kD);
  expect_only_failing(g, "contaminated");
  EXPECT_EQ(condition(g, "contaminated").candidate, 1);
}

TEST(PairedGate, WithoutABareCampaignTheThirdConditionIsVacuous) {
  const auto g = paired_gate(kParent, both("SSSF", "SSSH"), {}, kD);
  EXPECT_TRUE(g.pass);
  EXPECT_TRUE(g.pi_vacuous);
  EXPECT_NE(condition(g, "bare_policy_pairs").detail.find("vacuous"), std::string::npos);
}

TEST(PairedGate, AnEpisodeTheCandidateLacksFailsTheGateAndEpisodesOutsideDAreIgnored) {
  auto candidate = both("SSSF", "SSSH");
  candidate.pop_back();
  const auto g = paired_gate(kParent, candidate, kBare, kD);
  EXPECT_FALSE(g.pass);
  ASSERT_EQ(g.unpaired.size(), 1u);
  EXPECT_EQ(g.unpaired.front(), "goal-task/1 seed 4");
  auto outside = both("SSSF", "SSSH");
  for (auto& e : episodes("long", 3, "FFFF")) outside.push_back(e);
  EXPECT_TRUE(paired_gate(kParent, outside, kBare, kD).pass) << "long/3 is not in D";
}

TEST(Contamination, NamesEachCause) {
  EpisodeRecord r;
  r.success = true;
  r.evidence_path = "runs/evidence/e.jsonl";
  EXPECT_EQ(contamination(r, "lib-a", std::string("lib-a"), true), "");
  EXPECT_NE(contamination(r, "lib-a", std::string("lib-b"), true).find("lib-b"), std::string::npos);
  EXPECT_NE(contamination(r, "lib-a", std::nullopt, std::nullopt).find("e.jsonl"), std::string::npos);
  EXPECT_NE(contamination(r, "lib-a", std::string("lib-a"), false).find("evidence says failure"),
            std::string::npos);
  r.infrastructure = true;
  r.reason = "simulator worker lost";
  EXPECT_NE(contamination(r, "lib-a", std::string("lib-a"), true).find("infrastructure"), std::string::npos);
}

TEST(BroaderRegression, PairedSuccessesMustNotFallOverEveryCell) {
  const std::set<std::string> cells{"goal-swap", "goal-task"};
  EXPECT_TRUE(broader_regression(kParent, both("SSSF", "SSSH"), cells).pass);
  // The paper's rejected hob candidate in small: better where it was aimed, worse elsewhere.
  const auto hob = broader_regression(kParent, both("SSSS", "FFFH"), cells);
  EXPECT_FALSE(hob.pass);
  EXPECT_EQ(hob.parent, 5);
  EXPECT_EQ(hob.candidate, 4);
  EXPECT_EQ(hob.lost,
            (std::vector<std::string>{"goal-task/1 seed 1", "goal-task/1 seed 2", "goal-task/1 seed 3"}));
  EXPECT_EQ(hob.gained, (std::vector<std::string>{"goal-swap/5 seed 3", "goal-swap/5 seed 4"}));
  EXPECT_TRUE(broader_regression(kParent, both("SSSS", "FSSH"), cells).pass)
      << "as many successes: not fallen";
  const auto short_round =
      broader_regression(kParent, both("SSSF", "SSSH"), {"goal-swap", "goal-task", "long"});
  EXPECT_FALSE(short_round.pass);
  EXPECT_EQ(short_round.missing_cells, std::vector<std::string>{"long"});
  EXPECT_FALSE(broader_regression(kParent, both("SXSF", "SSSH"), cells).pass) << "a contaminated episode";
}

TEST(DominantCapability, TheMostHarnessFailuresAmongRevisableCapabilities) {
  const auto row = [](std::string capability, bool harness) {
    GateRow r;
    r.episode.harness_failure = harness;
    r.signature = Signature{std::move(capability), "grasp_missed", "close", 40};
    return r;
  };
  const std::set<std::string> revisable{"pick_place", "push", "slide_drawer"};
  EXPECT_EQ(dominant_capability(
                {row("push", true), row("pick_place", true), row("pick_place", true), row("vla_act", true),
                 row("vla_act", true), row("vla_act", true), row("slide_drawer", false),
                 row("slide_drawer", false), row("slide_drawer", false)},
                revisable),
            "pick_place")
      << "vla_act has no θ to revise; failures no harness layer owns do not count";
  EXPECT_EQ(dominant_capability({row("push", true), row("pick_place", true)}, revisable), "pick_place")
      << "a tie";
  EXPECT_EQ(dominant_capability({}, revisable), "");
}
