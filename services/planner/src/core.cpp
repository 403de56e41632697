#include "dh/planner/core.hpp"

#include "dh/planner/errors.hpp"

namespace dh::planner {
namespace {

Answer answer(const Request& r, PlannerAdvice a) {
  PlannerError injected = PlannerError::None;
  if (!r.errors.none()) injected = make_wrong(a, r.context, draw_planner_error(r.errors, r.seed, r.index));
  return {r.channel, r.request_id, r.episode_id, std::move(a), injected};
}

}  // namespace

PlannerCore::~PlannerCore() { stop(); }

const Ports& PlannerCore::ports() {
  static const Ports p{
      in_port<port::PlanRequest>("instruction, scene, the capabilities offered, the episode's history"),
      in_port<port::Announce>("each capability's argument roles, for the model's schema"),
      out_port<port::Advice>("the next step (and the rest), or a refusal with its reason"),
  };
  return p;
}

void PlannerCore::on_announce(const std::string& capability, std::vector<std::string> roles) {
  roles_[capability] = std::move(roles);
}

std::variant<Answer, Job> PlannerCore::on_request(Request r) {
  if (backend_ == Backend::Rules) {
    PlannerAdvice a = plan_rules(r.context);
    return answer(r, std::move(a));
  }
  auto& live = live_[r.channel];
  if (live) *live = true;
  live = std::make_shared<std::atomic<bool>>(false);
  return Job{std::move(r), roles_, live};
}

std::optional<Answer> PlannerCore::on_advice(const Job& job, PlannerAdvice advice) {
  if (*job.cancelled) return std::nullopt;
  live_.erase(job.request.channel);
  return answer(job.request, std::move(advice));
}

void PlannerCore::stop() {
  for (auto& [channel, flag] : live_) *flag = true;
  live_.clear();
}

}  // namespace dh::planner
