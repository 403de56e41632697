// The planner's core: the rules backend answers at once, with the planner error its request's rates draw;
// a model backend's requests are jobs, at most one live per channel (a newer request cancels the older
// job, whose answer is dropped; other channels are untouched); a job carries the roles announced before
// its request; stopping cancels every live job.
#include <gtest/gtest.h>

#include "dh/planner/core.hpp"
#include "dh/planner/errors.hpp"

using namespace dh;
using namespace dh::planner;

namespace {

EntityState entity(const std::string& name, const std::string& category) {
  EntityState s;
  s.name = name;
  s.kind = category;
  s.category = category;
  return s;
}

Request request(std::uint32_t channel, const std::string& id, PlannerErrorRates errors = {}) {
  return {channel,
          id,
          "episode-" + std::to_string(channel),
          {"put the bowl on the plate",
           {entity("bowl", "bowl"), entity("plate", "plate")},
           {"pick_place", "push"},
           {}},
          21,
          0,
          errors};
}

PlannerAdvice advice(const std::string& capability) {
  PlannerAdvice a;
  a.capability = capability;
  a.args = {{"object", "bowl"}, {"target", "plate"}};
  return a;
}

}  // namespace

TEST(PlannerCore, TheRulesBackendAnswersAtOnceWithTheRulesAdvice) {
  PlannerCore core(PlannerCore::Backend::Rules);
  const auto out = core.on_request(request(3, "r1"));
  ASSERT_TRUE(std::holds_alternative<Answer>(out));
  const Answer& a = std::get<Answer>(out);
  EXPECT_EQ(a.channel, 3u);
  EXPECT_EQ(a.request_id, "r1");
  EXPECT_EQ(a.episode_id, "episode-3");
  EXPECT_EQ(a.injected, PlannerError::None);
  const PlannerAdvice rules = plan_rules(request(3, "r1").context);
  EXPECT_FALSE(a.advice.refused) << a.advice.reason;
  EXPECT_EQ(a.advice.capability, rules.capability);
  EXPECT_EQ(a.advice.args, rules.args);
}

TEST(PlannerCore, AnAnswerCarriesTheErrorItsRequestsRatesDraw) {
  PlannerCore core(PlannerCore::Backend::Rules);
  const PlannerErrorRates always_wrong_capability{1.0, 0, 0, 0};
  const Answer a = std::get<Answer>(core.on_request(request(0, "r1", always_wrong_capability)));
  EXPECT_EQ(a.injected, PlannerError::WrongCapability);
  EXPECT_EQ(a.advice.capability, "push") << "the other eligible capability";
  // The same draw as the perturbation makes on its own.
  PlannerAdvice expected = plan_rules(request(0, "r1").context);
  EXPECT_EQ(
      make_wrong(expected, request(0, "r1").context, draw_planner_error(always_wrong_capability, 21, 0)),
      a.injected);
  EXPECT_EQ(a.advice.capability, expected.capability);
  EXPECT_EQ(a.advice.args, expected.args);
}

TEST(PlannerCore, ANewerRequestForAChannelCancelsTheOlderJobWhoseAnswerIsDropped) {
  PlannerCore core(PlannerCore::Backend::Model);
  const Job first = std::get<Job>(core.on_request(request(0, "r1")));
  const Job other = std::get<Job>(core.on_request(request(1, "q1")));
  EXPECT_FALSE(*first.cancelled);
  const Job second = std::get<Job>(core.on_request(request(0, "r2")));
  EXPECT_TRUE(*first.cancelled) << "the older request of channel 0 is still live";
  EXPECT_FALSE(*second.cancelled);
  EXPECT_FALSE(*other.cancelled) << "another channel's request was cancelled";

  EXPECT_FALSE(core.on_advice(first, advice("pick_place"))) << "a superseded answer was published";
  const auto answer = core.on_advice(second, advice("pick_place"));
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->request_id, "r2");
  EXPECT_EQ(answer->advice.capability, "pick_place");
  const auto other_answer = core.on_advice(other, advice("push"));
  ASSERT_TRUE(other_answer);
  EXPECT_EQ(other_answer->channel, 1u);
  EXPECT_EQ(other_answer->advice.capability, "push");
}

TEST(PlannerCore, AJobCarriesTheRolesAnnouncedBeforeItsRequest) {
  PlannerCore core(PlannerCore::Backend::Model);
  core.on_announce("pick_place", {"object", "target"});
  const Job job = std::get<Job>(core.on_request(request(0, "r1")));
  core.on_announce("push", {"object", "target"});
  EXPECT_EQ(job.roles.size(), 1u);
  EXPECT_EQ(job.roles.at("pick_place"), (std::vector<std::string>{"object", "target"}));
  EXPECT_EQ(core.roles().size(), 2u);
}

TEST(PlannerCore, StoppingCancelsEveryLiveJob) {
  PlannerCore core(PlannerCore::Backend::Model);
  const Job a = std::get<Job>(core.on_request(request(0, "r1")));
  const Job b = std::get<Job>(core.on_request(request(1, "q1")));
  core.stop();
  EXPECT_TRUE(*a.cancelled);
  EXPECT_TRUE(*b.cancelled);
  EXPECT_FALSE(core.on_advice(a, advice("pick_place")));
}
