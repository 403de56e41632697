// Spreading a campaign's episodes over every live simulator channel: which episode goes to which idle
// channel, which result closes which episode, and which episodes are lost to infrastructure (no result
// before their deadline). Pure logic: the `dh campaign` node feeds it what it hears on DDS.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dh/campaign/plan.hpp"
#include "dh/common/command.hpp"
#include "dh/common/episode_record.hpp"

namespace dh::campaign {

using Clock = std::chrono::steady_clock;

struct Dispatch {
  EpisodeKey key;
  std::uint32_t channel = 0;
  std::string episode_id;
};

/// What an episode result says (the fields of msg::EpisodeResult the campaign keeps).
struct ResultInfo {
  std::string episode_id;
  bool success = false;
  unsigned steps = 0;
  Outcome outcome = Outcome::GaveUp;
  std::string reason, evidence_path;
  std::vector<std::string> capabilities_missing;  ///< what the arm ran without
};

/// What a channel reports of its last finished episode beside its physics time: the simulator's own verdict.
struct SimVerdict {
  std::int32_t goal_step = -1;  ///< the first step the goal held (-1: never)
  bool goal_at_end = false;     ///< the goal held in the state the episode ended in
};

struct SchedulerOptions {
  std::string run_tag;  ///< makes episode ids unique across runs of one campaign (e.g. time + pid)
  /// An episode without a result after start_allowance + budget × per_step_allowance is an
  /// infrastructure loss.
  std::chrono::milliseconds start_allowance{30000};
  std::chrono::milliseconds per_step_allowance{200};
  /// How long a finished episode waits for its channel's physics report before it is recorded without.
  std::chrono::milliseconds physics_wait{2000};
  /// The rerun rule: an episode lost to infrastructure (no result in time, its worker lost, refused by
  /// the simulator or the governor) is run again up to this many times; each lost attempt is handed out
  /// by take_losses(), and the last attempt is the episode's record.
  unsigned reruns = 0;
  /// After the simulator ended an episode itself (its physics failed), the governor still runs it until it
  /// misses its next observation (step_stall_timeout_ms) and rejects requests for that channel meanwhile:
  /// the channel is not used until the governor's result for it comes, or this long at most.
  std::chrono::milliseconds governor_release{30000};
};

class Scheduler {
 public:
  Scheduler(std::vector<EpisodeKey> todo, std::function<unsigned(const EpisodeKey&)> budget_of,
            SchedulerOptions options);

  /// A channel announced its state; `last_episode`/`last_physics_s`/`verdict` report its last finished
  /// episode and `last_error` why it could not run it (then that episode ends at once as an infrastructure
  /// loss).
  void channel_status(std::uint32_t channel, const std::string& worker, bool idle, const std::string& last_episode,
                      double last_physics_s, const std::string& last_error, Clock::time_point now,
                      SimVerdict verdict = {});
  /// Pairs pending episodes with free channels (lowest channel first); the caller sends the requests.
  /// Pending episodes for which `skip` holds (recorded meanwhile by another process) are dropped.
  std::vector<Dispatch> assign(Clock::time_point now, const std::function<bool(const EpisodeKey&)>& skip = {});
  /// A result for one of this campaign's running episodes (others are ignored), or the governor's result
  /// for an episode the simulator had ended already, which frees its channel.
  void result(const ResultInfo& r, Clock::time_point now);
  /// Episodes whose deadline passed become infrastructure losses; their channels are not used again
  /// until they announce themselves idle after that.
  void expire(Clock::time_point now);
  /// `worker` is gone (its announcements lost liveliness): what its channels were running is lost at
  /// once, and they are not used again until they announce themselves again or the worker comes back.
  void worker_lost(const std::string& worker, Clock::time_point now);
  /// `worker`'s announcements are alive again (it was starved, not dead): its channels are in the state
  /// they last announced. A worker announces only changes, so a channel idle when it was lost would
  /// otherwise never serve again.
  void worker_back(const std::string& worker);
  /// Finished episodes ready to be recorded (their channel's report arrived or stopped being awaited).
  std::vector<EpisodeRecord> take_finished(Clock::time_point now);
  /// Attempts lost to infrastructure that were put back to run again (SchedulerOptions::reruns).
  std::vector<EpisodeRecord> take_losses();

  bool done() const { return pending_.empty() && running_.empty() && finishing_.empty(); }
  std::size_t pending() const { return pending_.size(); }
  std::size_t running() const { return running_.size(); }
  /// Non-empty when two workers announce the same channel id (requests are routed by id alone).
  const std::string& conflict() const { return conflict_; }

 private:
  struct ChannelInfo {
    std::string worker;
    bool idle = false;
    bool announced_idle = false;  ///< what it last announced (idle may be cleared meanwhile)
    bool lost = false;  ///< its worker lost liveliness and the channel has not been heard of since
    bool ours = false;  ///< we dispatched to it and it has not announced itself idle since
    std::string last_episode;  ///< the last episode it announced as finished
    std::string governor_episode;  ///< the simulator ended it, the governor has not yet (governor_release)
    Clock::time_point governor_until{};
  };
  struct Running {
    EpisodeKey key;
    std::uint32_t channel = 0;
    std::string worker;
    Clock::time_point started, deadline;
    unsigned budget = 0;
  };
  struct Finishing {
    EpisodeRecord record;
    Clock::time_point wait_until;
  };
  EpisodeRecord record_of(const Running& r, Clock::time_point now) const;
  void lose(std::map<std::string, Running>::iterator it, const std::string& reason, Clock::time_point now);
  /// Under the rerun rule, keeps `rec` as a lost attempt and puts its episode back first in line.
  bool rerun(const EpisodeRecord& rec);

  std::deque<EpisodeKey> pending_;
  std::function<unsigned(const EpisodeKey&)> budget_of_;
  SchedulerOptions options_;
  std::map<std::uint32_t, ChannelInfo> channels_;
  std::map<std::string, Running> running_;     ///< by episode id
  std::map<std::string, Finishing> finishing_; ///< by episode id
  struct SimReport {
    double physics_s = 0;
    std::optional<SimVerdict> verdict;  ///< none when the channel could not run the episode
  };
  std::map<std::string, SimReport> reports_;   ///< episode id → what its channel reported of it
  std::map<EpisodeKey, unsigned> reruns_;      ///< attempts put back per episode
  std::vector<EpisodeRecord> losses_;
  std::size_t dispatched_ = 0;
  std::string conflict_;
};

}  // namespace dh::campaign
