// dh_planner: the slow-brain proxy. Backend `rules` (embedded, deterministic); the `openai` backend
// arrives with the model-backends issue.
//
// Reads   rt/dh/planner/request (Planner) context snapshot
// Writes  rt/dh/planner/advice  (Planner) capability + symbolic arguments, or a refusal with its reason
// Parameters: --backend rules
#include <CLI/CLI.hpp>

#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/planner/rules.hpp"

namespace dh {
namespace {

int run(int argc, char** argv) {
  CLI::App app{"dh_planner: slow-brain proxy"};
  std::string backend = "rules";
  app.add_option("--backend", backend, "planner backend")->check(CLI::IsMember({"rules"}));
  CLI11_PARSE(app, argc, argv);
  auto log = make_logger("dh_planner");
  return run_service(*log, [&] {
    dds::Participant participant("dh_planner");
    EventQueue<msg::PlanRequest> q;
    dds::Writer<msg::AdvicePubSubType> advice(participant, topics::kAdvice, dds::Qos::Planner);
    dds::Reader<msg::PlanRequestPubSubType> req(participant, topics::kPlanRequest, dds::Qos::Planner,
        {[&](const msg::PlanRequest& m, const auto&) { q.push(m); }, {}, {}});
    log->info("backend={} domain={} up", backend, dds::domain_id());
    while (!shutdown_requested()) {
      auto r = q.pop(std::chrono::milliseconds(50));
      if (!r) continue;
      const planner::PlannerAdvice a =
          planner::plan_rules({r->instruction(), convert::from_msg(r->scene()), r->capabilities(), r->history()});
      msg::Advice m;
      m.channel(r->channel());
      m.request_id(r->request_id());
      m.episode_id(r->episode_id());
      m.refused(a.refused);
      m.capability(a.capability);
      m.args(convert::to_msg(a.args));
      m.rationale(a.rationale);
      m.reason(a.reason);
      m.backend(backend);
      m.done(a.done);
      for (const auto& st : a.rest) {
        msg::PlanStep p;
        p.capability(st.capability);
        p.args(convert::to_msg(st.args));
        m.rest().push_back(std::move(p));
      }
      advice.write(m);
      log->info("channel={} request={} -> {}", r->channel(), r->request_id(),
                a.refused ? "refused: " + a.reason : a.capability);
    }
  });
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
