// dh_planner: the slow-brain proxy. Backends: `rules` (embedded, deterministic) and `openai` (any
// OpenAI-compatible chat-completions endpoint: vLLM, llama.cpp's llama-server, Ollama).
//
// Reads   rt/dh/planner/request (Planner) context snapshot
//         rt/dh/capability/announce (Announce) argument roles of each capability (openai: for the prompt)
// Writes  rt/dh/planner/advice  (Planner) capability + symbolic arguments, or a refusal with its reason
// Parameters: --backend rules|openai; openai: --endpoint URL --model NAME [--api-key-env VAR]
//             [--timeout-s 90] [--workers 8] [--system-prompt-file FILE]
//
// `rules` answers on the node's thread in arrival order. `openai` requests run on a pool of workers, so
// a slow model on one channel never holds up the others; a newer request for a channel supersedes an
// older one still queued or in flight (the governor waits only for its latest request per channel).
// Every failure of the model server is an Advice with refused = true and the reason.
#include <CLI/CLI.hpp>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <mutex>
#include <sstream>
#include <thread>

#include "dh/common/convert.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/event_queue.hpp"
#include "dh/common/log.hpp"
#include "dh/common/service.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/planner/curl_transport.hpp"
#include "dh/planner/errors.hpp"
#include "dh/planner/openai.hpp"
#include "dh/planner/rules.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

msg::Advice to_msg(const msg::PlanRequest& r, const planner::PlannerAdvice& a, PlannerError injected,
                   const std::string& backend) {
  msg::Advice m;
  m.injected(convert::to_msg(injected));
  m.channel(r.channel());
  m.request_id(r.request_id());
  m.episode_id(r.episode_id());
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
  return m;
}

planner::PlanContext context(const msg::PlanRequest& r) {
  return {r.instruction(), convert::from_msg(r.scene()), r.capabilities(), r.history()};
}

/// Argument roles per capability, as the capability processes announce them.
class RoleBook {
 public:
  void add(const msg::CapabilityAnnounce& a) {
    std::lock_guard lock(mutex_);
    roles_[a.capability()] = a.arguments();
  }
  planner::CapabilityRoles snapshot() const {
    std::lock_guard lock(mutex_);
    return roles_;
  }

 private:
  mutable std::mutex mutex_;
  planner::CapabilityRoles roles_;
};

/// Runs plan requests on `workers` threads; at most one live request per channel.
class RequestPool {
 public:
  using Work = std::function<void(const msg::PlanRequest&, const std::function<bool()>& stale)>;

  RequestPool(std::size_t workers, Work work, spdlog::logger& log) : work_(std::move(work)), log_(log) {
    for (std::size_t i = 0; i < workers; ++i) threads_.emplace_back([this] { loop(); });
  }
  ~RequestPool() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }
  RequestPool(const RequestPool&) = delete;
  RequestPool& operator=(const RequestPool&) = delete;

  void submit(msg::PlanRequest r) {
    {
      std::lock_guard lock(mutex_);
      for (auto it = queue_.begin(); it != queue_.end();) {
        if (it->channel() == r.channel()) {
          log_.info("channel={} request={} superseded by {} before it started", it->channel(),
                    it->request_id(), r.request_id());
          it = queue_.erase(it);
        } else {
          ++it;
        }
      }
      latest_[r.channel()] = r.request_id();
      queue_.push_back(std::move(r));
    }
    cv_.notify_one();
  }

  /// Whether `r` is no longer worth answering: a newer request for its channel, or the node stops.
  bool stale(const msg::PlanRequest& r) {
    std::lock_guard lock(mutex_);
    return stopping_ || shutdown_requested() || latest_[r.channel()] != r.request_id();
  }

 private:
  void loop() {
    while (true) {
      msg::PlanRequest r;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_) return;
        r = std::move(queue_.front());
        queue_.pop_front();
      }
      try {
        work_(r, [this, &r] { return stale(r); });
      } catch (const std::exception& e) {  // a worker must not take the process down
        log_.error("channel={} request={} failed: {}", r.channel(), r.request_id(), e.what());
      }
    }
  }

  Work work_;
  spdlog::logger& log_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<msg::PlanRequest> queue_;
  std::map<std::uint32_t, std::string> latest_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read --system-prompt-file " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int run(int argc, char** argv) {
  CLI::App app{"dh_planner: slow-brain proxy"};
  std::string backend = "rules";
  planner::OpenAiConfig oc;
  double timeout_s = 90;
  std::size_t workers = 8;
  std::string prompt_file;
  app.add_option("--backend", backend, "planner backend")->check(CLI::IsMember({"rules", "openai"}));
  app.add_option("--endpoint", oc.endpoint, "openai: server root, e.g. http://127.0.0.1:8000");
  app.add_option("--model", oc.model, "openai: model name as the server knows it");
  app.add_option("--api-key-env", oc.api_key_env, "openai: environment variable holding a bearer token");
  app.add_option("--timeout-s", timeout_s, "openai: seconds per plan request, repair included")
      ->check(CLI::Range(0.1, 3600.0));
  app.add_option("--workers", workers, "openai: requests served at once")->check(CLI::Range(1, 256));
  app.add_option("--system-prompt-file", prompt_file, "openai: replaces the built-in system prompt");
  CLI11_PARSE(app, argc, argv);
  if (backend == "openai" && (oc.endpoint.empty() || oc.model.empty())) {
    std::cerr << "dh_planner: --backend openai needs --endpoint URL and --model NAME\n";
    return 2;
  }
  oc.timeout = std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000));
  auto log = make_logger("dh_planner");
  std::optional<dds::Participant> participant;
  std::optional<dds::Writer<msg::AdvicePubSubType>> advice;
  std::optional<dds::Reader<msg::PlanRequestPubSubType>> requests;
  std::optional<dds::Reader<msg::CapabilityAnnouncePubSubType>> announcements;
  EventQueue<msg::PlanRequest> q;
  RoleBook roles;
  std::mutex write_mutex;
  std::unique_ptr<planner::CurlTransport> http;
  std::unique_ptr<planner::OpenAiPlanner> model;
  std::unique_ptr<RequestPool> pool;
  auto publish = [&](const msg::PlanRequest& r, planner::PlannerAdvice a, Clock::time_point t0) {
    // The request's planner-error rates make the backend's advice wrong on purpose, whichever backend.
    PlannerError injected = PlannerError::None;
    if (const PlannerErrorRates rates = convert::from_msg(r.errors()); !rates.none())
      injected = planner::make_wrong(a, context(r), draw_planner_error(rates, r.seed(), r.index()));
    const auto ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    {
      std::lock_guard lock(write_mutex);
      advice->write(to_msg(r, a, injected, backend));
    }
    if (a.refused)
      log->info("channel={} request={} {:.1f} ms -> refused: {}", r.channel(), r.request_id(), ms, a.reason);
    else
      log->info("channel={} request={} {:.1f} ms -> {} {}", r.channel(), r.request_id(), ms, a.capability,
                a.rationale);
  };

  ManagedService service;
  service.transitions.configure = [&] {
    if (!prompt_file.empty()) oc.system_prompt = read_file(prompt_file);
    participant.emplace("dh_planner");
    advice.emplace(*participant, topics::kAdvice, dds::Qos::Planner);
    if (backend != "openai") return;
    http = std::make_unique<planner::CurlTransport>();  // libcurl initialized before the workers start
    model = std::make_unique<planner::OpenAiPlanner>(oc, *http);
    if (!model->key_problem().empty()) log->warn("every request will be refused: {}", model->key_problem());
  };
  service.transitions.activate = [&] {
    announcements.emplace(*participant, topics::kAnnounce, dds::Qos::Announce,
                          dds::Reader<msg::CapabilityAnnouncePubSubType>::Callbacks{
                              [&](const msg::CapabilityAnnounce& m, const auto&) { roles.add(m); }, {}, {}});
    requests.emplace(*participant, topics::kPlanRequest, dds::Qos::Planner,
                     dds::Reader<msg::PlanRequestPubSubType>::Callbacks{
                         [&](const msg::PlanRequest& m, const auto&) { q.push(m); }, {}, {}});
    if (!model) {
      log->info("backend={} domain={} up", backend, dds::domain_id());
      return;
    }
    pool = std::make_unique<RequestPool>(
        workers,
        [&](const msg::PlanRequest& r, const std::function<bool()>& stale) {
          const auto t0 = Clock::now();
          // PlanRequest carries no camera images yet (the governor does not attach rt/dh/camera's): the
          // model reads the scene as text. OpenAiPlanner attaches images when given (image_url parts).
          const planner::PlannerAdvice a = model->plan(context(r), roles.snapshot(), {}, stale);
          if (stale()) {
            log->info("channel={} request={} superseded (or the planner stops): answer dropped", r.channel(),
                      r.request_id());
            return;
          }
          publish(r, a, t0);
        },
        *log);
    log->info("backend=openai endpoint={} model={} timeout={:g} s workers={} domain={} up", model->url(), oc.model,
              timeout_s, workers, dds::domain_id());
  };
  service.transitions.deactivate = [&] {
    requests.reset();
    announcements.reset();
    pool.reset();  // in-flight transfers see the stop within about a second
  };
  service.transitions.shutdown = [&] {
    requests.reset();
    announcements.reset();
    pool.reset();
    model.reset();
    http.reset();
    advice.reset();
    participant.reset();
  };
  service.step = [&] {
    auto r = q.pop(std::chrono::milliseconds(50));
    if (!r) return;
    if (pool) {
      log->debug("channel={} request={} queued", r->channel(), r->request_id());
      pool->submit(std::move(*r));
      return;
    }
    const auto t0 = Clock::now();
    publish(*r, planner::plan_rules(context(*r)), t0);
  };
  return run_managed(*log, std::move(service));
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::run(argc, argv); }
