// The rules slow brain: clause parsing, noun-phrase resolution, next-step selection from the history, and
// refusals (whole plans on real scenes: test_planner_paraphrases.cpp).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "dh/planner/core.hpp"

#include "dh/common/history.hpp"
#include "dh/planner/rules.hpp"

using namespace dh;
using namespace dh::planner;

namespace {
// A scene entity as the workcell reports it: what a person calls it (category, colour), where it stands,
// and, for parts and regions, what owns them and how.
EntityState e(const std::string& name, const std::string& kind, const std::string& category, double x = 0,
              double y = 0, double z = 0, const std::string& colour = "") {
  EntityState s;
  s.name = name;
  s.kind = kind;
  s.category = category;
  s.colour = colour;
  s.p = {x, y, z};
  return s;
}
EntityState part(const std::string& name, const std::string& kind, const std::string& owner, double z = 0) {
  EntityState s = e(name, kind, kind, 0, 0, z);
  s.owner = owner;
  return s;
}
EntityState region(const std::string& name, const std::string& owner, const std::string& relation, double x = 0) {
  EntityState s = e(name, "region", "", x);
  s.owner = owner;
  s.relation = relation;
  return s;
}

// kitchen_goal as the workcell observes it (positions only where the parser reads them).
std::vector<EntityState> kitchen() {
  return {e("bowl", "bowl", "bowl", 0, 0, 0, "black"), e("plate", "plate", "plate", 0, 0, 0, "white"),
          e("cream_cheese", "box", "cream cheese", 0, 0, 0, "white"), e("wine_bottle", "cylinder", "wine bottle"),
          e("cabinet", "cabinet", "cabinet"), e("stove", "stove", "stove"), e("wine_rack", "wine_rack", "wine rack"),
          part("cabinet_top_drawer", "drawer", "cabinet", 0.2), part("cabinet_middle_drawer", "drawer", "cabinet", 0.13),
          part("cabinet_bottom_drawer", "drawer", "cabinet", 0.05), part("stove_knob", "knob", "stove"),
          region("cabinet_top_side", "cabinet", "on"), region("cabinet_top_region", "cabinet_top_drawer", "in"),
          region("cabinet_middle_region", "cabinet_middle_drawer", "in"),
          region("cabinet_bottom_region", "cabinet_bottom_drawer", "in"), region("stove_cook_region", "stove", "on"),
          region("stove_front_region", "stove", "front_of"), region("wine_rack_top_region", "wine_rack", "on")};
}

const std::vector<std::string> kAll{"pick_place", "push", "slide_drawer", "turn_knob", "swing_door"};

PlanContext ctx(const std::string& instruction, std::vector<EntityState> scene = kitchen()) {
  return {instruction, std::move(scene), kAll, {}};
}

using Steps = std::vector<std::pair<std::string, Args>>;
Steps steps(const std::string& instruction, const std::vector<EntityState>& scene = kitchen()) {
  Steps out;
  for (const auto& s : plan_steps(instruction, scene)) out.emplace_back(s.capability, s.args);
  return out;
}
}  // namespace

TEST(Rules, PutTheBowlOnThePlate) {
  const auto a = plan_rules(ctx("put the bowl on the plate"));
  ASSERT_FALSE(a.refused) << a.reason;
  EXPECT_EQ(a.capability, "pick_place");
  EXPECT_EQ(a.args, (Args{{"object", "bowl"}, {"target", "plate"}}));
  EXPECT_TRUE(a.rest.empty());
}

TEST(Rules, NounPhrasesResolveToEntitiesPartsAndRegions) {
  const auto k = kitchen();
  EXPECT_EQ(resolve("the black bowl", k), std::vector<std::string>{"bowl"});
  EXPECT_EQ(resolve("the cream cheese box", k), std::vector<std::string>{"cream_cheese"});
  EXPECT_EQ(resolve("the top drawer of the cabinet", k), std::vector<std::string>{"cabinet_top_drawer"});
  EXPECT_EQ(resolve("the front of the stove", k), std::vector<std::string>{"stove_front_region"});
  EXPECT_EQ(resolve("the rack", k), std::vector<std::string>{"wine_rack"});
  EXPECT_TRUE(resolve("the mug", k).empty());
  const std::vector<EntityState> mugs{e("white_mug", "mug", "mug", 0, 0, 0, "white"),
                                      e("yellow_white_mug", "mug", "mug", 0, 0, 0, "yellow and white"),
                                      e("red_mug", "mug", "mug", 0, 0, 0, "red")};
  EXPECT_EQ(resolve("the white mug", mugs), std::vector<std::string>{"white_mug"});
  EXPECT_EQ(resolve("the yellow and white mug", mugs), std::vector<std::string>{"yellow_white_mug"});
  EXPECT_EQ(resolve("the yellow cup", mugs), std::vector<std::string>{"yellow_white_mug"}) << "by colour, not by name";
  EXPECT_TRUE(resolve("the mug", mugs).empty()) << "three mugs: ambiguous";
  const std::vector<EntityState> pots{e("moka_pot_1", "moka_pot", "moka pot", 0, -0.2),
                                      e("moka_pot_2", "moka_pot", "moka pot", 0, 0.2)};
  EXPECT_EQ(resolve("both moka pots", pots), (std::vector<std::string>{"moka_pot_1", "moka_pot_2"}));
  EXPECT_EQ(resolve("the left moka pot", pots), std::vector<std::string>{"moka_pot_2"}) << "left is +y";
  EXPECT_EQ(resolve("the right moka pot", pots), std::vector<std::string>{"moka_pot_1"});
  const std::vector<EntityState> caddy{e("caddy", "caddy", "caddy"), region("caddy_back_contain_region", "caddy", "in", 0.05),
                                       region("caddy_front_contain_region", "caddy", "in", -0.05)};
  EXPECT_EQ(resolve("the back compartment of the caddy", caddy), std::vector<std::string>{"caddy_back_contain_region"});
  EXPECT_EQ(resolve("the caddy's front compartment", caddy), std::vector<std::string>{"caddy_front_contain_region"});
  EXPECT_EQ(resolve("the top of the cabinet", k), std::vector<std::string>{"cabinet_top_side"}) << "not the top drawer";
  EXPECT_EQ(resolve("the lowest drawer", k), std::vector<std::string>{"cabinet_bottom_drawer"});
  EXPECT_EQ(resolve("the cupboard's second drawer", k), std::vector<std::string>{"cabinet_middle_drawer"});
}

TEST(Rules, ClausesBecomeStepsInOrder) {
  EXPECT_EQ(steps("open the top drawer and put the bowl inside"),
            (Steps{{"slide_drawer", {{"drawer", "cabinet_top_drawer"}, {"state", "open"}}},
                   {"pick_place", {{"object", "bowl"}, {"target", "cabinet_top_region"}}}}));
  EXPECT_EQ(steps("put the black bowl in the bottom drawer of the cabinet and close it"),
            (Steps{{"pick_place", {{"object", "bowl"}, {"target", "cabinet_bottom_region"}}},
                   {"slide_drawer", {{"drawer", "cabinet_bottom_drawer"}, {"state", "closed"}}}}));
  EXPECT_EQ(steps("turn on the stove and put the bowl on it"),
            (Steps{{"turn_knob", {{"knob", "stove_knob"}, {"state", "on"}}},
                   {"pick_place", {{"object", "bowl"}, {"target", "stove_cook_region"}}}}));
  EXPECT_EQ(steps("push the plate to the front of the stove"),
            (Steps{{"push", {{"object", "plate"}, {"target", "stove_front_region"}}}}));
  const std::vector<EntityState> room{e("plate", "plate", "plate"), region("plate_right_region", "plate", "right_of"),
                                      e("white_mug", "mug", "mug", 0, 0, 0, "white"),
                                      e("chocolate_pudding", "box", "chocolate pudding"), e("basket", "basket", "basket"),
                                      region("basket_contain_region", "basket", "in"), e("book", "book", "book")};
  EXPECT_EQ(steps("put the white mug on the plate and put the chocolate pudding to the right of the plate", room),
            (Steps{{"pick_place", {{"object", "white_mug"}, {"target", "plate"}}},
                   {"pick_place", {{"object", "chocolate_pudding"}, {"target", "plate_right_region"}}}}));
  EXPECT_EQ(steps("put both the book and the white mug in the basket", room),
            (Steps{{"pick_place", {{"object", "book"}, {"target", "basket_contain_region"}}},
                   {"pick_place", {{"object", "white_mug"}, {"target", "basket_contain_region"}}}}));
  EXPECT_EQ(steps("pick up the book and place it in the basket", room),
            (Steps{{"pick_place", {{"object", "book"}, {"target", "basket_contain_region"}}}}));
}

TEST(Rules, TheNextStepIsTheFirstWhoseArgumentsHaveNotCompleted) {
  PlanContext c = ctx("open the top drawer and put the bowl inside");
  auto a = plan_rules(c);
  ASSERT_FALSE(a.refused);
  EXPECT_EQ(a.capability, "slide_drawer");
  ASSERT_EQ(a.rest.size(), 1u);
  c.history.push_back(history::outcome_line(90, "slide_drawer", "failed", a.args, "short of open"));
  EXPECT_EQ(plan_rules(c).capability, "slide_drawer") << "a failed step is still open";
  c.history.push_back(history::outcome_line(150, "slide_drawer", "completed", a.args, ""));
  a = plan_rules(c);
  EXPECT_EQ(a.capability, "pick_place");
  EXPECT_TRUE(a.rest.empty());
  // Whichever capability completed the arguments (a substitution) counts.
  c.history.push_back(history::outcome_line(280, "push", "completed", a.args, ""));
  a = plan_rules(c);
  EXPECT_TRUE(a.refused);
  EXPECT_TRUE(a.done);
}

TEST(Rules, WhatCannotBeFormedIsARefusalWithItsReason) {
  auto a = plan_rules(ctx("put the mug on the plate"));
  EXPECT_TRUE(a.refused);
  EXPECT_EQ(a.why, PlannerRefusal::Planning);
  EXPECT_EQ(a.reason, "no 'mug' in this scene");
  EXPECT_FALSE(a.done);
  a = plan_rules(ctx("dance"));
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("does not understand"), std::string::npos);
  a = plan_rules(ctx(""));
  EXPECT_TRUE(a.refused);
  a = plan_rules(ctx("close it"));
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("'it'"), std::string::npos) << a.reason;
  PlanContext none = ctx("put the bowl on the plate");
  none.capabilities.clear();
  a = plan_rules(none);
  EXPECT_TRUE(a.refused);
  EXPECT_NE(a.reason.find("no eligible capability"), std::string::npos);
  none.capabilities = {"vla_act", "regrasp"};
  a = plan_rules(none);
  EXPECT_FALSE(a.refused) << "without pick_place the learned policy is handed the instruction";
  EXPECT_EQ(a.capability, "vla_act");
  EXPECT_EQ(a.args, (Args{{"instruction", "put the bowl on the plate"}}));
}

TEST(Rules, SynonymsCoordinationAndCoreference) {
  EXPECT_EQ(steps("switch the stove on"), (Steps{{"turn_knob", {{"knob", "stove_knob"}, {"state", "on"}}}}));
  EXPECT_EQ(steps("shut the top drawer"),
            (Steps{{"slide_drawer", {{"drawer", "cabinet_top_drawer"}, {"state", "closed"}}}}));
  EXPECT_EQ(steps("grab the bowl and place it on the plate"),
            (Steps{{"pick_place", {{"object", "bowl"}, {"target", "plate"}}}}));
  EXPECT_EQ(steps("put the bowl on the top of the cabinet"),
            (Steps{{"pick_place", {{"object", "bowl"}, {"target", "cabinet_top_side"}}}}));
  EXPECT_EQ(steps("could you put the cream cheese in the bowl, then put the bowl on the plate for me"),
            (Steps{{"pick_place", {{"object", "cream_cheese"}, {"target", "bowl"}}},
                   {"pick_place", {{"object", "bowl"}, {"target", "plate"}}}}));
  EXPECT_EQ(steps("put the wine bottle on the rack and the cream cheese too"),
            (Steps{{"pick_place", {{"object", "wine_bottle"}, {"target", "wine_rack_top_region"}}},
                   {"pick_place", {{"object", "cream_cheese"}, {"target", "wine_rack_top_region"}}}}));
  EXPECT_EQ(steps("close the top drawer after putting the bowl in it"),
            (Steps{{"pick_place", {{"object", "bowl"}, {"target", "cabinet_top_region"}}},
                   {"slide_drawer", {{"drawer", "cabinet_top_drawer"}, {"state", "closed"}}}}));
  EXPECT_EQ(steps("open the bottom drawer, then close the one you opened"),
            (Steps{{"slide_drawer", {{"drawer", "cabinet_bottom_drawer"}, {"state", "open"}}},
                   {"slide_drawer", {{"drawer", "cabinet_bottom_drawer"}, {"state", "closed"}}}}));
}

TEST(Rules, ARefusalNamesTheWordsItCouldNotPlace) {
  auto reason = [](const std::string& instruction, std::vector<EntityState> scene = kitchen()) {
    try {
      plan_steps(instruction, scene);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("planned");
  };
  EXPECT_EQ(reason("put the banana on the plate"), "no 'banana' in this scene");
  const std::vector<EntityState> mugs{e("white_mug", "mug", "mug", 0, 0, 0, "white"), e("red_mug", "mug", "mug", 0, 0, 0, "red"),
                                      e("plate", "plate", "plate")};
  EXPECT_EQ(reason("put the mug on the plate", mugs), "'the mug' could be white_mug or red_mug: say which");
  EXPECT_EQ(reason("put the bowl to the left of the plate"), "no place to the left of 'the plate' in this scene");
  EXPECT_EQ(reason("open the fourth drawer"), "'the fourth drawer': there are only 3 (cabinet_top_drawer, cabinet_middle_drawer or cabinet_bottom_drawer)");
}

TEST(PlannerPorts, MatchTheServiceReadme) {
  const char* home = std::getenv("DH_HOME");
  ASSERT_TRUE(home) << "DH_HOME names the checkout";
  EXPECT_EQ(dh::port_table(std::filesystem::path(home) / "services/planner/README.md"),
            dh::port_table(dh::planner::PlannerCore::ports()));
}
