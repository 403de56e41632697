// dh_planner: the slow-brain proxy. Backends: `rules` (embedded, deterministic) and `openai` (any
// OpenAI-compatible chat-completions endpoint: vLLM, llama.cpp's llama-server, Ollama).
//
// Reads   rt/dh/planner/request (Planner) context snapshot
//         rt/dh/capability/announce (Announce) argument roles of each capability (openai: for the prompt)
// Writes  rt/dh/planner/advice  (Planner) capability + symbolic arguments, or a refusal with its reason
// Parameters: --backend rules|openai; openai: --endpoint URL --model NAME [--api-key-env VAR]
//             [--timeout-s 90] [--workers 8] [--system-prompt-file FILE]
//
// Run by the one DDS shell (dds_shell.hpp). `rules` answers on the shell's loop in arrival order. `openai`
// requests run on a pool of workers, so a slow model on one channel never holds up the others; a newer
// request for a channel supersedes an older one still queued or in flight (the governor waits only for its
// latest request per channel); answers are written from the loop. Every failure of the model server is an
// Advice with refused = true and the reason.
#include <CLI/CLI.hpp>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "dh/common/convert.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/planner/curl_transport.hpp"
#include "dh/planner/errors.hpp"
#include "dh/planner/openai.hpp"
#include "dh/planner/ports.hpp"
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

/// Runs plan requests on `workers` threads; at most one live request per channel.
class RequestPool {
 public:
  using Work = std::function<void(const msg::PlanRequest&, const planner::CapabilityRoles&,
                                  const std::function<bool()>& stale)>;

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

  /// `roles`: the argument roles announced when the request arrived.
  void submit(msg::PlanRequest r, planner::CapabilityRoles roles) {
    {
      std::lock_guard lock(mutex_);
      for (auto it = queue_.begin(); it != queue_.end();) {
        if (it->first.channel() == r.channel()) {
          log_.info("channel={} request={} superseded by {} before it started", it->first.channel(),
                    it->first.request_id(), r.request_id());
          it = queue_.erase(it);
        } else {
          ++it;
        }
      }
      latest_[r.channel()] = r.request_id();
      queue_.emplace_back(std::move(r), std::move(roles));
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
      std::pair<msg::PlanRequest, planner::CapabilityRoles> job;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      const msg::PlanRequest& r = job.first;
      try {
        work_(r, job.second, [this, &r] { return stale(r); });
      } catch (const std::exception& e) {  // a worker must not take the process down
        log_.error("channel={} request={} failed: {}", r.channel(), r.request_id(), e.what());
      }
    }
  }

  Work work_;
  spdlog::logger& log_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::pair<msg::PlanRequest, planner::CapabilityRoles>> queue_;
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

class PlannerBinding {
 public:
  using Inputs = dds::Inputs<dds::In<port::PlanRequest>, dds::In<port::Announce>>;
  using Outputs = dds::Outputs<port::Advice>;
  using Context = dds::Context<PlannerBinding>;

  std::string name() const { return "dh_planner"; }
  std::string description() const { return "slow-brain proxy"; }
  const Ports& ports() const { return planner::ports(); }
  void options(CLI::App& app) {
    app.add_option("--backend", backend_, "planner backend")->check(CLI::IsMember({"rules", "openai"}));
    app.add_option("--endpoint", oc_.endpoint, "openai: server root, e.g. http://127.0.0.1:8000");
    app.add_option("--model", oc_.model, "openai: model name as the server knows it");
    app.add_option("--api-key-env", oc_.api_key_env, "openai: environment variable holding a bearer token");
    app.add_option("--timeout-s", timeout_s_, "openai: seconds per plan request, repair included")
        ->check(CLI::Range(0.1, 3600.0));
    app.add_option("--workers", workers_, "openai: requests served at once")->check(CLI::Range(1, 256));
    app.add_option("--system-prompt-file", prompt_file_, "openai: replaces the built-in system prompt");
  }
  void parsed() {
    if (backend_ == "openai" && (oc_.endpoint.empty() || oc_.model.empty()))
      throw std::invalid_argument("--backend openai needs --endpoint URL and --model NAME");
    oc_.timeout = std::chrono::milliseconds(static_cast<long long>(timeout_s_ * 1000));
  }

  void configure(Context& ctx) {
    if (!prompt_file_.empty()) oc_.system_prompt = read_file(prompt_file_);
    if (backend_ != "openai") return;
    http_ = std::make_unique<planner::CurlTransport>();  // libcurl initialized before the workers start
    model_ = std::make_unique<planner::OpenAiPlanner>(oc_, *http_);
    if (!model_->key_problem().empty()) ctx.log.warn("every request will be refused: {}", model_->key_problem());
  }
  void activate(Context& ctx) {
    if (!model_) {
      ctx.log.info("backend={} domain={} up", backend_, dds::domain_id());
      return;
    }
    pool_ = std::make_unique<RequestPool>(
        workers_,
        [this, &ctx](const msg::PlanRequest& r, const planner::CapabilityRoles& roles,
                     const std::function<bool()>& stale) {
          const auto t0 = Clock::now();
          // PlanRequest carries no camera images yet (the governor does not attach rt/dh/camera's): the
          // model reads the scene as text. OpenAiPlanner attaches images when given (image_url parts).
          planner::PlannerAdvice a = model_->plan(context(r), roles, {}, stale);
          if (stale()) {
            ctx.log.info("channel={} request={} superseded (or the planner stops): answer dropped", r.channel(),
                         r.request_id());
            return;
          }
          ctx.post([this, &ctx, r, a = std::move(a), t0]() mutable { publish(ctx, r, std::move(a), t0); });
        },
        ctx.log);
    ctx.log.info("backend=openai endpoint={} model={} timeout={:g} s workers={} domain={} up", model_->url(), oc_.model,
                 timeout_s_, workers_, dds::domain_id());
  }

  void on(const dds::Sample<port::Announce>& s, Context&) { roles_[s.msg.capability()] = s.msg.arguments(); }
  void on(const dds::Sample<port::PlanRequest>& s, Context& ctx) {
    const msg::PlanRequest& r = s.msg;
    if (pool_) {
      ctx.log.debug("channel={} request={} queued", r.channel(), r.request_id());
      pool_->submit(r, roles_);
      return;
    }
    const auto t0 = Clock::now();
    publish(ctx, r, planner::plan_rules(context(r)), t0);
  }

  void deactivate(Context&) { pool_.reset(); }  // in-flight transfers see the stop within about a second
  void shutdown() {
    pool_.reset();
    model_.reset();
    http_.reset();
  }

 private:
  void publish(Context& ctx, const msg::PlanRequest& r, planner::PlannerAdvice a, Clock::time_point t0) {
    // The request's planner-error rates make the backend's advice wrong on purpose, whichever backend.
    PlannerError injected = PlannerError::None;
    if (const PlannerErrorRates rates = convert::from_msg(r.errors()); !rates.none())
      injected = planner::make_wrong(a, context(r), draw_planner_error(rates, r.seed(), r.index()));
    const auto ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    ctx.write<port::Advice>(to_msg(r, a, injected, backend_));
    if (a.refused)
      ctx.log.info("channel={} request={} {:.1f} ms -> refused: {}", r.channel(), r.request_id(), ms, a.reason);
    else
      ctx.log.info("channel={} request={} {:.1f} ms -> {} {}", r.channel(), r.request_id(), ms, a.capability,
                   a.rationale);
  }

  std::string backend_ = "rules";
  planner::OpenAiConfig oc_;
  double timeout_s_ = 90;
  std::size_t workers_ = 8;
  std::string prompt_file_;
  planner::CapabilityRoles roles_;  ///< argument roles per capability, as the capability processes announce them
  std::unique_ptr<planner::CurlTransport> http_;
  std::unique_ptr<planner::OpenAiPlanner> model_;
  std::unique_ptr<RequestPool> pool_;
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::PlannerBinding{}); }
