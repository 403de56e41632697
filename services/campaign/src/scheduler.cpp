#include "dh/campaign/scheduler.hpp"

#include "dh/common/clock.hpp"

namespace dh::campaign {

Scheduler::Scheduler(std::vector<EpisodeKey> todo, std::function<unsigned(const EpisodeKey&)> budget_of,
                     SchedulerOptions options)
    : pending_(todo.begin(), todo.end()), budget_of_(std::move(budget_of)), options_(std::move(options)) {}

void Scheduler::channel_status(std::uint32_t channel, const std::string& worker, bool idle,
                               const std::string& last_episode, double last_physics_s, const std::string& last_error,
                               Clock::time_point now, SimVerdict verdict) {
  auto& c = channels_[channel];
  if (!c.worker.empty() && c.worker != worker && conflict_.empty())
    conflict_ = "channel " + std::to_string(channel) + " is announced by two workers, '" + c.worker + "' and '" +
                worker + "'; give each worker its own --first-channel range";
  c.worker = worker;
  c.idle = c.announced_idle = idle;
  c.lost = false;
  if (!last_episode.empty()) {
    // A channel that could not run the episode has no verdict on it (its loss is recorded without one).
    reports_[last_episode] = {last_physics_s, last_error.empty() ? std::optional(verdict) : std::nullopt};
    c.last_episode = last_episode;
    const auto it = running_.find(last_episode);
    if (idle && !last_error.empty() && it != running_.end()) {
      lose(it, "simulator: " + last_error, now);
      c.governor_episode = last_episode;
      c.governor_until = now + options_.governor_release;
    }
  }
  // Our episode on it is over only once its result came: an idle announcement that crosses our request
  // (sent before the channel saw it) must not free the channel.
  if (idle && c.ours) {
    bool still_running = false;
    for (const auto& [id, r] : running_) still_running |= r.channel == channel;
    if (!still_running) c.ours = false;
  }
}

std::vector<Dispatch> Scheduler::assign(Clock::time_point now, const std::function<bool(const EpisodeKey&)>& skip) {
  std::vector<Dispatch> out;
  for (auto& [id, c] : channels_) {
    while (skip && !pending_.empty() && skip(pending_.front())) pending_.pop_front();
    if (pending_.empty()) break;
    if (!c.idle || c.ours || (!c.governor_episode.empty() && now < c.governor_until)) continue;
    Dispatch d{pending_.front(), id, ""};
    pending_.pop_front();
    d.episode_id = d.key.arm + "-" + d.key.cell + "-t" + std::to_string(d.key.task) + "-s" +
                   std::to_string(d.key.seed) + "-" + options_.run_tag + "-" + std::to_string(dispatched_++);
    const unsigned budget = budget_of_(d.key);
    running_[d.episode_id] = {d.key, id, c.worker, now,
                              now + options_.start_allowance + budget * options_.per_step_allowance, budget};
    c.ours = true;
    c.idle = false;
    out.push_back(std::move(d));
  }
  return out;
}

EpisodeRecord Scheduler::record_of(const Running& r, Clock::time_point now) const {
  EpisodeRecord rec;
  rec.arm = r.key.arm;
  rec.cell = r.key.cell;
  rec.task = r.key.task;
  rec.seed = r.key.seed;
  rec.budget = r.budget;
  rec.wall_s = std::chrono::duration<double>(now - r.started).count();
  rec.worker = r.worker;
  rec.channel = r.channel;
  rec.finished_at = utc_time("%Y-%m-%dT%H:%M:%SZ");
  return rec;
}

void Scheduler::result(const ResultInfo& r, Clock::time_point now) {
  for (auto& [id, c] : channels_)
    if (c.governor_episode == r.episode_id) c.governor_episode.clear();
  const auto it = running_.find(r.episode_id);
  if (it == running_.end()) return;
  EpisodeRecord rec = record_of(it->second, now);
  rec.episode_id = r.episode_id;
  rec.success = r.success;
  rec.steps = r.steps;
  rec.outcome = to_string(r.outcome);
  rec.reason = r.reason;
  rec.evidence_path = r.evidence_path;
  // A request the governor rejected never started, so nothing ran without anything.
  if (r.outcome != Outcome::Rejected) rec.capabilities_missing = r.capabilities_missing;
  // "rejected": the governor refused the request itself (unknown arm, busy channel): not the agent's failure.
  rec.infrastructure = lost_to_infrastructure(r.outcome);
  rec.tick_limit = r.outcome == Outcome::BudgetExhausted;
  if (rec.infrastructure && rerun(rec)) {
    running_.erase(it);
    return;
  }
  // The channel may have announced itself idle after this episode before its result reached us.
  auto& c = channels_[it->second.channel];
  if (c.idle && c.last_episode == r.episode_id) c.ours = false;
  running_.erase(it);
  finishing_[r.episode_id] = {std::move(rec), now + options_.physics_wait};
}

void Scheduler::lose(std::map<std::string, Running>::iterator it, const std::string& reason, Clock::time_point now) {
  EpisodeRecord rec = record_of(it->second, now);
  rec.episode_id = it->first;
  rec.outcome = to_string(Outcome::Infrastructure);
  rec.infrastructure = true;
  rec.reason = reason;
  if (!rerun(rec)) finishing_[it->first] = {std::move(rec), now};
  running_.erase(it);
}

bool Scheduler::rerun(const EpisodeRecord& rec) {
  const EpisodeKey key{rec.arm, rec.cell, rec.task, rec.seed};
  unsigned& n = reruns_[key];
  if (n >= options_.reruns) return false;
  ++n;
  losses_.push_back(rec);
  pending_.push_front(key);
  return true;
}

void Scheduler::worker_lost(const std::string& worker, Clock::time_point now) {
  for (auto& [id, c] : channels_)
    if (c.worker == worker) {
      c.idle = false;
      c.ours = false;
      c.lost = true;
    }
  for (auto it = running_.begin(); it != running_.end();) {
    if (it->second.worker != worker) {
      ++it;
      continue;
    }
    const std::string reason = "worker " + worker + " lost on channel " + std::to_string(it->second.channel) +
                               " (its announcements' liveliness lease expired: process dead or host cut off)";
    lose(it++, reason, now);
  }
}

void Scheduler::worker_back(const std::string& worker) {
  for (auto& [id, c] : channels_)
    if (c.worker == worker && c.lost) {
      c.lost = false;
      c.idle = c.announced_idle;
    }
}

std::vector<EpisodeRecord> Scheduler::take_losses() {
  std::vector<EpisodeRecord> out;
  out.swap(losses_);
  return out;
}

void Scheduler::expire(Clock::time_point now) {
  for (auto it = running_.begin(); it != running_.end();) {
    if (now < it->second.deadline) {
      ++it;
      continue;
    }
    const auto& r = it->second;
    // The channel stays ours (unusable) until it announces itself idle again.
    channels_[r.channel].idle = false;
    const std::string reason =
        "no result within " + std::to_string(std::chrono::duration_cast<std::chrono::seconds>(r.deadline - r.started).count()) +
        " s on channel " + std::to_string(r.channel) + " (worker " + r.worker + ")";
    lose(it++, reason, now);
  }
}

std::vector<EpisodeRecord> Scheduler::take_finished(Clock::time_point now) {
  std::vector<EpisodeRecord> out;
  for (auto it = finishing_.begin(); it != finishing_.end();) {
    const auto p = reports_.find(it->first);
    if (p == reports_.end() && now < it->second.wait_until) {
      ++it;
      continue;
    }
    if (p != reports_.end()) {
      auto& rec = it->second.record;
      rec.physics_s = p->second.physics_s;
      if (const auto& v = p->second.verdict) {
        rec.sim_success = v->goal_step >= 0;
        rec.sim_goal_step = v->goal_step;
        rec.sim_goal_at_end = v->goal_at_end;
      }
      reports_.erase(p);
    }
    out.push_back(std::move(it->second.record));
    it = finishing_.erase(it);
  }
  return out;
}

}  // namespace dh::campaign
