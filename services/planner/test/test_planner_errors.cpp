// The planner-error perturbation: the draw is reproducible and meets its rates; each error changes the
// advice as declared, and one that does not apply leaves it as it is.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "dh/common/config.hpp"
#include "dh/common/history.hpp"
#include "dh/common/paths.hpp"
#include "dh/planner/errors.hpp"

using namespace dh;
using namespace dh::planner;

namespace {

EntityState entity(const std::string& name, const std::string& kind, const std::string& category,
                   const std::string& colour = "") {
  EntityState s;
  s.name = name;
  s.kind = kind;
  s.category = category;
  s.colour = colour;
  return s;
}

// A table with a bowl, a plate and a basket: "put the bowl on the plate, then put the plate in the basket"
// is two steps.
PlanContext context(std::vector<std::string> history = {}) {
  EntityState basket_in = entity("basket_contain_region", "region", "");
  basket_in.owner = "basket";
  basket_in.relation = "in";
  return {"put the bowl on the plate, then put the plate in the basket",
          {entity("bowl", "bowl", "bowl", "black"), entity("plate", "plate", "plate", "white"),
           entity("basket", "basket", "basket"), basket_in},
          {"pick_place", "push", "vla_act"},
          std::move(history)};
}

}  // namespace

TEST(PlannerErrors, TheDrawIsReproducibleAndMeetsItsRates) {
  const PlannerErrorRates rates{0.1, 0.05, 0.05, 0.2};
  std::map<PlannerError, int> seen;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const PlannerErrorDraw d = draw_planner_error(rates, 21 + i / 20, i % 20);
    const PlannerErrorDraw again = draw_planner_error(rates, 21 + i / 20, i % 20);
    ASSERT_EQ(d.error, again.error);
    ASSERT_EQ(d.pick, again.pick);
    ASSERT_GE(d.pick, 0.0);
    ASSERT_LT(d.pick, 1.0);
    ++seen[d.error];
  }
  // Binomial standard errors are at most 0.003 here: 0.012 is four of them.
  EXPECT_NEAR(seen[PlannerError::WrongCapability] / double(n), 0.1, 0.012);
  EXPECT_NEAR(seen[PlannerError::WrongArgument] / double(n), 0.05, 0.012);
  EXPECT_NEAR(seen[PlannerError::DroppedStep] / double(n), 0.05, 0.012);
  EXPECT_NEAR(seen[PlannerError::RepeatedStep] / double(n), 0.2, 0.012);
  EXPECT_NEAR(seen[PlannerError::None] / double(n), 0.6, 0.012);
  for (std::uint32_t i = 0; i < 100; ++i)
    EXPECT_EQ(draw_planner_error(PlannerErrorRates{}, 7, i).error, PlannerError::None);
}

TEST(PlannerErrors, TheDrawSeedTellsTasksApartButNotArms) {
  EXPECT_EQ(planner_error_seed("goal", 3, 21), planner_error_seed("goal", 3, 21));
  EXPECT_NE(planner_error_seed("goal", 3, 21), planner_error_seed("goal", 4, 21));
  EXPECT_NE(planner_error_seed("goal", 3, 21), planner_error_seed("long", 3, 21));
  EXPECT_NE(planner_error_seed("goal", 3, 21), planner_error_seed("goal", 3, 22));
  // Tasks sharing a seed do not share their first requests' errors.
  const PlannerErrorRates rates{0.25, 0.25, 0.25, 0.25};
  std::set<PlannerError> first;
  for (std::uint32_t task = 0; task < 10; ++task)
    first.insert(draw_planner_error(rates, planner_error_seed("goal", task, 21), 0).error);
  EXPECT_GT(first.size(), 1u);
}

TEST(PlannerErrors, EachErrorChangesTheAdviceAsDeclared) {
  const PlanContext c = context();
  const PlannerAdvice right = plan_rules(c);
  ASSERT_EQ(right.capability, "pick_place");
  ASSERT_EQ(right.rest.size(), 1u);

  PlannerAdvice a = right;
  EXPECT_EQ(make_wrong(a, c, {PlannerError::WrongCapability, 0.0}), PlannerError::WrongCapability);
  EXPECT_EQ(a.capability, "push") << "another eligible capability, never vla_act";
  EXPECT_EQ(a.args, right.args);
  EXPECT_NE(a.rationale.find("[planner error: wrong_capability]"), std::string::npos);

  a = right;
  EXPECT_EQ(make_wrong(a, c, {PlannerError::WrongArgument, 0.99}), PlannerError::WrongArgument);
  EXPECT_EQ(a.capability, right.capability);
  int changed = 0;
  for (std::size_t i = 0; i < a.args.size(); ++i) changed += a.args[i] != right.args[i];
  EXPECT_EQ(changed, 1);

  a = right;
  EXPECT_EQ(make_wrong(a, c, {PlannerError::DroppedStep, 0.5}), PlannerError::DroppedStep);
  EXPECT_EQ(a.args, right.rest.front().args) << "the next step instead";
  EXPECT_TRUE(a.rest.empty());

  // Nothing has completed: there is no step to repeat.
  a = right;
  EXPECT_EQ(make_wrong(a, c, {PlannerError::RepeatedStep, 0.5}), PlannerError::None);
  EXPECT_EQ(a.args, right.args);
  EXPECT_EQ(a.rationale, right.rationale);

  // After the first step: it is advised again, the right step behind it.
  const PlanContext later = context({history::outcome_line(80, "pick_place", "completed", right.args, "")});
  const PlannerAdvice second = plan_rules(later);
  ASSERT_EQ(second.args, right.rest.front().args);
  a = second;
  EXPECT_EQ(make_wrong(a, later, {PlannerError::RepeatedStep, 0.5}), PlannerError::RepeatedStep);
  EXPECT_EQ(a.args, right.args);
  ASSERT_EQ(a.rest.size(), 1u);
  EXPECT_EQ(a.rest.front().args, second.args);
  // The last step has no later one to drop to.
  a = second;
  EXPECT_EQ(make_wrong(a, later, {PlannerError::DroppedStep, 0.5}), PlannerError::None);
  EXPECT_EQ(a.args, second.args);
}

TEST(PlannerErrors, ARefusalIsLeftAsItIs) {
  PlanContext c = context();
  c.instruction = "juggle the plate";
  PlannerAdvice a = plan_rules(c);
  ASSERT_TRUE(a.refused);
  const PlannerAdvice before = a;
  EXPECT_EQ(make_wrong(a, c, {PlannerError::WrongCapability, 0.1}), PlannerError::None);
  EXPECT_EQ(a.reason, before.reason);
}

TEST(PlannerErrors, TheShippedProfilesLoadAndBadOnesAreNamed) {
  const auto file = paths::config_dir() / "planner_errors.yaml";
  const PlannerErrorRates vlm = load_planner_errors(file, "vlm");
  EXPECT_DOUBLE_EQ(vlm.total(), 0.2);
  EXPECT_FALSE(vlm.none());
  try {
    load_planner_errors(file, "nope");
    FAIL() << "an unknown profile loaded";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no planner-error profile 'nope' (profiles: "), std::string::npos) << e.what();
  }
  const auto bad = std::filesystem::path(::testing::TempDir()) / "dh_planner_errors_bad.yaml";
  std::ofstream(bad) << "profiles:\n  x: {wrong_capability: 0.7, dropped_step: 0.5}\n";
  try {
    load_planner_errors(bad, "x");
    FAIL() << "rates above 1 loaded";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("above 1"), std::string::npos) << e.what();
  }
  std::filesystem::remove(bad);
}
