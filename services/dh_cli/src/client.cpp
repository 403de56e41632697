#include "client.hpp"

#include <iostream>
#include <thread>

#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/topics.hpp"
#include "dh/sim/predicates.hpp"
#include "dh/sim/scene.hpp"

namespace dh::cli {

using Clock = std::chrono::steady_clock;

Client::Client(dds::Participant& p)
    : request_(p, topics::kEpisodeRequest, dds::Qos::Episode),
      channels_(p, topics::kChannelStatus, dds::Qos::ChannelStatus,
                {[this](const msg::ChannelStatus& s, const eprosima::fastdds::dds::SampleInfo& info) {
                   std::lock_guard l(m_);
                   idle_[s.channel()] = s.state() == msg::CHANNEL_IDLE;
                   workers_.saw(info.publication_handle, s.worker());
                   news_.channels.push_back(s);
                   cv_.notify_all();
                 },
                 // A worker whose announcements stop being alive (process dead, host cut off) has lost
                 // whatever its channels were running; one that was only starved comes back alive.
                 [this](const eprosima::fastdds::dds::LivelinessChangedStatus& st) {
                   std::lock_guard l(m_);
                   const auto change = workers_.changed(st);
                   if (!change) return;
                   (change->alive ? news_.returned_workers : news_.lost_workers).push_back(change->worker);
                   cv_.notify_all();
                 },
                 {}}),
      caps_(p, topics::kAnnounce, dds::Qos::Announce,
            {[this](const msg::CapabilityAnnounce& a, const auto&) {
               std::lock_guard l(m_);
               capabilities_.insert(a.capability());
               cv_.notify_all();
             }, {}, {}}),
      results_(p, topics::kEpisodeResult, dds::Qos::Episode,
               {[this](const msg::EpisodeResult& r, const auto&) {
                  std::lock_guard l(m_);
                  results_seen_[r.episode_id()] = r;
                  news_.results.push_back(r);
                  cv_.notify_all();
                }, {}, {}}) {}

std::optional<std::uint32_t> Client::wait_ready(const std::string& capability, std::optional<std::uint32_t> want,
                                                std::chrono::milliseconds timeout) {
  std::unique_lock l(m_);
  std::optional<std::uint32_t> found;
  cv_.wait_for(l, timeout, [&] {
    // The episode request needs its two readers: a simulator worker and the governor.
    if (request_.matched() < 2 || !capabilities_.count(capability)) return false;
    for (const auto& [ch, idle] : idle_)
      if (idle && (!want || *want == ch)) {
        found = ch;
        return true;
      }
    return false;
  });
  return found;
}

std::optional<msg::EpisodeResult> Client::wait_result(const std::string& episode, std::chrono::milliseconds timeout) {
  std::unique_lock l(m_);
  const auto deadline = Clock::now() + timeout;
  while (!results_seen_.count(episode) && !shutdown_requested() && Clock::now() < deadline)
    cv_.wait_until(l, std::min(deadline, Clock::now() + std::chrono::milliseconds(200)));
  if (!results_seen_.count(episode)) return std::nullopt;
  return results_seen_.at(episode);
}

Client::News Client::take_news() {
  std::lock_guard l(m_);
  News n = std::move(news_);
  news_ = {};
  return n;
}

std::vector<msg::GoalTerm> goal_terms(const TaskDef& task) {
  return convert::to_msg(sim::goal_terms(sim::load_nominal_scene(task), task.goal));
}

std::optional<std::uint32_t> ensure_deployment(Client& client, const std::string& capability,
                                               std::optional<std::uint32_t> want, const std::string& launch_file,
                                               std::chrono::milliseconds ready, bool quiet,
                                               std::unique_ptr<Deployment>& local) {
  auto ch = client.wait_ready(capability, want, ready);
  if (ch) return ch;
  const auto file = launch_file.empty() ? paths::home() / "deploy" / "local.yaml" : std::filesystem::path(launch_file);
  if (!quiet) std::cerr << "no deployment answered; starting " << file.string() << "\n";
  local = std::make_unique<Deployment>(load_launch_file(file), paths::bin_dir(), paths::runs_dir() / "logs");
  ch = client.wait_ready(capability, want, std::chrono::seconds(20));
  if (!ch) {
    std::cerr << "error: the deployment " << file.string() << " did not become ready in 20 s; see logs in "
              << local->log_dir().string() << "\n";
    return std::nullopt;
  }
  // Let the governor's own discovery of the capability and planner settle.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  return ch;
}

}  // namespace dh::cli
