// dh_planner: the slow-brain proxy. Backends: `rules` (embedded, deterministic) and `openai` (any
// OpenAI-compatible chat-completions endpoint: vLLM, llama.cpp's llama-server, Ollama).
//
// Reads   rt/dh/planner/request (Planner) context snapshot
//         rt/dh/capability/announce (Announce) argument roles of each capability (openai: for the prompt)
// Writes  rt/dh/planner/advice  (Planner) capability + symbolic arguments, or a refusal with its reason
// Parameters: --backend rules|openai; openai: --endpoint URL --model NAME [--api-key-env VAR]
//             [--timeout-s 90] [--workers 8] [--system-prompt-file FILE]
//
// planner::PlannerCore (core.hpp) holds the rules: `rules` answers at once, on the shell's loop in arrival
// order; an `openai` request is a job, at most one live per channel. Here the jobs run on a pool of workers,
// so a slow model on one channel never holds up the others; a job superseded while queued is skipped, one
// in flight sees its flag and gives up; answers come back to the loop and are written from there. Every
// failure of the model server is an Advice with refused = true and the reason.
#include <CLI/CLI.hpp>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "dh/common/convert.hpp"
#include "dh/common/dds_shell.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/plannerPubSubTypes.h"
#include "dh/planner/curl_transport.hpp"
#include "dh/planner/openai.hpp"
#include "dh/planner/core.hpp"
#include "dh/planner/rules.hpp"

namespace dh {
namespace {

using Clock = std::chrono::steady_clock;

msg::Advice to_msg(const planner::Answer& answer, const std::string& backend) {
  const planner::PlannerAdvice& a = answer.advice;
  msg::Advice m;
  m.injected(convert::to_msg(answer.injected));
  m.channel(answer.channel);
  m.request_id(answer.request_id);
  m.episode_id(answer.episode_id);
  m.refused(a.refused);
  m.refusal(convert::to_msg(a.why));
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

planner::Request from_msg(const msg::PlanRequest& r) {
  return {r.channel(),
          r.request_id(),
          r.episode_id(),
          {r.instruction(), convert::from_msg(r.scene()), r.capabilities(), r.history()},
          r.seed(),
          r.index(),
          convert::from_msg(r.errors())};
}

/// Runs the model backend's jobs on `workers` threads; a job cancelled while queued is skipped.
class RequestPool {
 public:
  using Work = std::function<void(const planner::Job&, const std::function<bool()>& stale)>;

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

  void submit(planner::Job job) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(job));
    }
    cv_.notify_one();
  }

 private:
  void loop() {
    while (true) {
      planner::Job job;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      const planner::Request& r = job.request;
      if (*job.cancelled) {
        log_.info("channel={} request={} superseded before it started", r.channel, r.request_id);
        continue;
      }
      try {
        work_(job, [this, &job] { return *job.cancelled || stopping() || shutdown_requested(); });
      } catch (const std::exception& e) {  // a worker must not take the process down
        log_.error("channel={} request={} failed: {}", r.channel, r.request_id, e.what());
      }
    }
  }
  bool stopping() {
    std::lock_guard lock(mutex_);
    return stopping_;
  }

  Work work_;
  spdlog::logger& log_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<planner::Job> queue_;
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
  const Ports& ports() const { return planner::PlannerCore::ports(); }
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
    if (backend_ != "openai") {
      core_ = std::make_unique<planner::PlannerCore>(planner::PlannerCore::Backend::Rules);
      return;
    }
    core_ = std::make_unique<planner::PlannerCore>(planner::PlannerCore::Backend::Model);
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
        [this, &ctx](const planner::Job& job, const std::function<bool()>& stale) {
          const auto t0 = Clock::now();
          // PlanRequest carries no camera images yet (the governor does not attach rt/dh/camera's): the
          // model reads the scene as text. OpenAiPlanner attaches images when given (image_url parts).
          planner::PlannerAdvice a = model_->plan(job.request.context, job.roles, {}, stale);
          ctx.post([this, &ctx, job, a = std::move(a), t0]() mutable {
            if (auto answer = core_->on_advice(job, std::move(a))) publish(ctx, *answer, t0);
            else
              ctx.log.info("channel={} request={} superseded (or the planner stops): answer dropped",
                           job.request.channel, job.request.request_id);
          });
        },
        ctx.log);
    ctx.log.info("backend=openai endpoint={} model={} timeout={:g} s workers={} domain={} up", model_->url(), oc_.model,
                 timeout_s_, workers_, dds::domain_id());
  }

  void on(const dds::Sample<port::Announce>& s, Context&) {
    core_->on_announce(s.msg.capability(), s.msg.arguments());
  }
  void on(const dds::Sample<port::PlanRequest>& s, Context& ctx) {
    const auto t0 = Clock::now();
    auto out = core_->on_request(from_msg(s.msg));
    if (auto* job = std::get_if<planner::Job>(&out)) {
      ctx.log.debug("channel={} request={} queued", job->request.channel, job->request.request_id);
      pool_->submit(std::move(*job));
      return;
    }
    publish(ctx, std::get<planner::Answer>(out), t0);
  }

  void deactivate(Context&) {
    core_->stop();  // in-flight transfers see the stop within about a second
    pool_.reset();
  }
  void shutdown() {
    pool_.reset();
    model_.reset();
    http_.reset();
    core_.reset();
  }

 private:
  void publish(Context& ctx, const planner::Answer& answer, Clock::time_point t0) {
    const auto ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    ctx.write<port::Advice>(to_msg(answer, backend_));
    const planner::PlannerAdvice& a = answer.advice;
    if (a.refused)
      ctx.log.info("channel={} request={} {:.1f} ms -> refused: {}", answer.channel, answer.request_id, ms, a.reason);
    else
      ctx.log.info("channel={} request={} {:.1f} ms -> {} {}", answer.channel, answer.request_id, ms, a.capability,
                   a.rationale);
  }

  std::string backend_ = "rules";
  planner::OpenAiConfig oc_;
  double timeout_s_ = 90;
  std::size_t workers_ = 8;
  std::string prompt_file_;
  std::unique_ptr<planner::PlannerCore> core_;
  std::unique_ptr<planner::CurlTransport> http_;
  std::unique_ptr<planner::OpenAiPlanner> model_;
  std::unique_ptr<RequestPool> pool_;
};

}  // namespace
}  // namespace dh

int main(int argc, char** argv) { return dh::dds::run_service(argc, argv, dh::PlannerBinding{}); }
