// bench_rgbd_qos: how RGB-D frames (640x480: 1.5 MB) travel between two processes on the deployment's
// DDS profile (UDP on loopback, no shared memory), best effort against reliable keep-last 1.
//
//   bench_rgbd_qos [--qos reliable,best-effort] [--frames 200] [--mode request|stream] [--heartbeat-ms 100]
//
// request: the client asks (rt/dh/camera/rgbd/request, as perception will) and waits for the frame with
//          its id, up to --timeout-ms; it records request -> frame latency or a loss, then asks again.
// stream:  the server writes --frames frames back to back every --interval-ms; the client counts what
//          arrives (what --rgbd-every or frames_player --rate-hz would see).
// For each QoS the client starts the server (itself with --role server) as a separate process, on a
// domain of its own (DH_DOMAIN_ID, default 61). Not a test: prints a table.
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/cameraPubSubTypes.h"

namespace dh {
namespace {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string role = "client", qos = "reliable,best-effort", mode = "request";
  unsigned frames = 200, width = 640, height = 480, timeout_ms = 1000, interval_ms = 0;
  double heartbeat_ms = 100;
};

dds::QosPair variant(const std::string& qos, double heartbeat_ms) {
  auto q = dds::qos_for(dds::Qos::Rgbd);
  const auto kind = qos == "best-effort" ? fdds::BEST_EFFORT_RELIABILITY_QOS : fdds::RELIABLE_RELIABILITY_QOS;
  q.writer.reliability().kind = kind;
  q.reader.reliability().kind = kind;
  q.writer.history().kind = q.reader.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  q.writer.history().depth = q.reader.history().depth = 1;
  q.writer.durability().kind = q.reader.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  q.writer.reliable_writer_qos().times.heartbeatPeriod =
      eprosima::fastrtps::Duration_t(heartbeat_ms / 1000.0);
  return q;
}

template <class T>
class Listener : public fdds::DataReaderListener {
 public:
  explicit Listener(std::function<void(const T&)> f) : f_(std::move(f)) {}
  void on_data_available(fdds::DataReader* r) override {
    T s;
    fdds::SampleInfo info;
    while (r->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK)
      if (info.valid_data) f_(s);
  }

 private:
  std::function<void(const T&)> f_;
};

int server(const Options& o) {
  dds::Participant p("bench_rgbd_server");
  const auto q = variant(o.qos, o.heartbeat_ms);
  auto* writer = p.publisher()->create_datawriter(
      p.topic(topics::kRgbd, fdds::TypeSupport(new msg::RgbdFramePubSubType())), q.writer);
  msg::RgbdFrame frame;
  frame.channel(0);
  frame.camera("workcell");
  frame.width(o.width);
  frame.height(o.height);
  std::mt19937 rng(1);
  frame.rgb().resize(3ull * o.width * o.height);
  frame.depth().resize(2ull * o.width * o.height);
  for (auto& b : frame.rgb()) b = static_cast<std::uint8_t>(rng());  // incompressible, like a rendered image
  for (auto& b : frame.depth()) b = static_cast<std::uint8_t>(rng());
  std::atomic<bool> quit = false;
  std::mutex m;
  std::condition_variable cv;
  std::vector<msg::RgbdRequest> pending;
  Listener<msg::RgbdRequest> listener([&](const msg::RgbdRequest& r) {
    std::lock_guard l(m);
    pending.push_back(r);
    cv.notify_all();
  });
  const auto rq = dds::qos_for(dds::Qos::RgbdRequest);
  auto* reader = p.subscriber()->create_datareader(
      p.topic(topics::kRgbdRequest, fdds::TypeSupport(new msg::RgbdRequestPubSubType())), rq.reader,
      &listener);
  double write_s = 0;
  unsigned writes = 0;
  while (!quit) {
    std::vector<msg::RgbdRequest> todo;
    {
      std::unique_lock l(m);
      cv.wait_for(l, std::chrono::milliseconds(100), [&] { return !pending.empty(); });
      todo.swap(pending);
    }
    for (const auto& r : todo) {
      if (r.request_id() == "quit") {
        quit = true;
        break;
      }
      const unsigned n = r.request_id().rfind("stream", 0) == 0 ? o.frames : 1;
      for (unsigned k = 0; k < n; ++k) {
        frame.request_id(n == 1 ? r.request_id() : "s" + std::to_string(k));
        frame.step(k);
        const auto t0 = Clock::now();
        writer->write(&frame);
        write_s += std::chrono::duration<double>(Clock::now() - t0).count();
        ++writes;
        if (n > 1 && o.interval_ms) std::this_thread::sleep_for(std::chrono::milliseconds(o.interval_ms));
      }
    }
  }
  std::fprintf(stderr, "server %s: %u writes, %.2f ms per write() call\n", o.qos.c_str(), writes,
               writes ? 1e3 * write_s / writes : 0.0);
  p.subscriber()->delete_datareader(reader);
  p.publisher()->delete_datawriter(writer);
  return 0;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))];
}

int client(const Options& o, const std::string& exe) {
  std::printf("%u frames of %ux%u (%.2f MB), mode %s, heartbeat %.0f ms, profile %s\n", o.frames, o.width,
              o.height, 5.0 * o.width * o.height / 1e6, o.mode.c_str(), o.heartbeat_ms,
              paths::dds_profile().c_str());
  std::vector<std::string> kinds;
  for (std::size_t a = 0, b; a <= o.qos.size(); a = b + 1) {
    b = o.qos.find(',', a);
    if (b == std::string::npos) b = o.qos.size();
    kinds.push_back(o.qos.substr(a, b - a));
  }
  for (const auto& kind : kinds) {
    const pid_t pid = fork();
    if (pid == 0) {
      const std::string frames = std::to_string(o.frames), w = std::to_string(o.width),
                        h = std::to_string(o.height), hb = std::to_string(o.heartbeat_ms),
                        iv = std::to_string(o.interval_ms);
      execl(exe.c_str(), exe.c_str(), "--role", "server", "--qos", kind.c_str(), "--frames", frames.c_str(),
            "--width", w.c_str(), "--height", h.c_str(), "--heartbeat-ms", hb.c_str(), "--interval-ms",
            iv.c_str(), nullptr);
      _exit(127);
    }
    {
      dds::Participant p("bench_rgbd_client");
      const auto q = variant(kind, o.heartbeat_ms);
      std::mutex m;
      std::condition_variable cv;
      std::map<std::string, Clock::time_point> got;
      std::size_t bytes = 0;
      Listener<msg::RgbdFrame> listener([&](const msg::RgbdFrame& f) {
        std::lock_guard l(m);
        got.emplace(f.request_id(), Clock::now());
        bytes = f.rgb().size() + f.depth().size();
        cv.notify_all();
      });
      auto* reader = p.subscriber()->create_datareader(
          p.topic(topics::kRgbd, fdds::TypeSupport(new msg::RgbdFramePubSubType())), q.reader, &listener);
      dds::Writer<msg::RgbdRequestPubSubType> req(p, topics::kRgbdRequest, dds::Qos::RgbdRequest);
      const auto t_wait = Clock::now();
      while ((req.matched() < 1 ||
              [&] {
                fdds::SubscriptionMatchedStatus s;
                reader->get_subscription_matched_status(s);
                return s.current_count < 1;
              }()) &&
             Clock::now() - t_wait < std::chrono::seconds(10))
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      msg::RgbdRequest r;
      r.channel(0);
      r.camera("workcell");
      if (o.mode == "request") {
        std::vector<double> lat;
        unsigned lost = 0;
        const auto t0 = Clock::now();
        for (unsigned i = 0; i < o.frames; ++i) {
          const std::string id = "r" + std::to_string(i);
          r.request_id(id);
          const auto sent = Clock::now();
          req.write(r);
          std::unique_lock l(m);
          if (cv.wait_for(l, std::chrono::milliseconds(o.timeout_ms), [&] { return got.count(id) > 0; }))
            lat.push_back(std::chrono::duration<double, std::milli>(got[id] - sent).count());
          else
            ++lost;
        }
        const double s = std::chrono::duration<double>(Clock::now() - t0).count();
        std::printf(
            "%-12s request->frame: %u/%u answered, %u lost (no frame within %u ms); latency ms p50 %.1f  p90 "
            "%.1f  "
            "p99 %.1f  max %.1f; %.1f frames/s\n",
            kind.c_str(), static_cast<unsigned>(lat.size()), o.frames, lost, o.timeout_ms,
            percentile(lat, 0.5), percentile(lat, 0.9), percentile(lat, 0.99),
            lat.empty() ? 0 : *std::max_element(lat.begin(), lat.end()), lat.size() / s);
      } else {
        r.request_id("stream");
        const auto t0 = Clock::now();
        req.write(r);
        std::this_thread::sleep_for(std::chrono::milliseconds(o.frames * (o.interval_ms + 5) + 2000));
        std::lock_guard l(m);
        Clock::time_point last = t0;
        for (const auto& [id, t] : got) last = std::max(last, t);
        std::printf("%-12s stream of %u every %u ms: %zu arrived (%zu bytes each), last after %.0f ms\n",
                    kind.c_str(), o.frames, o.interval_ms, got.size(), bytes,
                    std::chrono::duration<double, std::milli>(last - t0).count());
      }
      r.request_id("quit");
      req.write(r);
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      p.subscriber()->delete_datareader(reader);
    }
    int status = 0;
    waitpid(pid, &status, 0);
  }
  return 0;
}

}  // namespace
}  // namespace dh

int main(int argc, char** argv) {
  dh::Options o;
  CLI::App app{"RGB-D frame delivery over DDS: best effort against reliable keep-last 1"};
  app.add_option("--role", o.role)->check(CLI::IsMember({"client", "server"}));
  app.add_option("--qos", o.qos, "comma-separated: reliable, best-effort");
  app.add_option("--mode", o.mode)->check(CLI::IsMember({"request", "stream"}));
  app.add_option("--frames", o.frames);
  app.add_option("--width", o.width);
  app.add_option("--height", o.height);
  app.add_option("--timeout-ms", o.timeout_ms);
  app.add_option("--interval-ms", o.interval_ms);
  app.add_option("--heartbeat-ms", o.heartbeat_ms, "reliable writer's heartbeat period");
  CLI11_PARSE(app, argc, argv);
  if (!std::getenv("DH_DOMAIN_ID")) setenv("DH_DOMAIN_ID", "61", 1);
  return o.role == "server" ? dh::server(o) : dh::client(o, dh::paths::self_exe().string());
}
