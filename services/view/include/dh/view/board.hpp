// The live view's state, DDS-free: every channel as the simulator workers announce it (rt/dh/sim/channel)
// and as the governor's core says its episode stands (rt/dh/evidence), and every campaign's progress
// (rt/dh/campaign/progress). The DDS shell (dh view) feeds it samples with the time they arrived; the page
// reads snapshot(). Memory is bounded: one row per channel, one per campaign, and a campaign not heard of
// for `forget_after` is dropped.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace dh::view {

using Clock = std::chrono::steady_clock;

/// A simulator channel's announcement (idl ChannelStatus).
struct ChannelAnnounce {
  std::uint32_t channel = 0;
  std::string worker;  ///< the sim_worker process that serves it
  bool running = false;
  std::string episode_id;
};

/// The governor's core on a channel's episode (idl EpisodeLive).
struct EpisodeLive {
  std::uint32_t channel = 0;
  std::string episode_id, arm, cell;
  std::uint32_t task = 0;
  std::uint64_t seed = 0;
  std::uint32_t step = 0, budget_steps = 0;
  std::string capability;        ///< in control, "" when none
  std::string decision, reason;  ///< the last decision and why
  bool ended = false;
  std::string outcome;           ///< with ended
  std::string evidence;          ///< the episode's evidence file
};

/// One arm × cell's tally in a campaign.
struct CellTally {
  std::string arm, cell;
  std::uint32_t successes = 0, episodes = 0;
};

/// A campaign's progress (idl CampaignProgress), as `dh campaign` publishes it after every episode.
struct CampaignProgress {
  std::string campaign;  ///< its database
  std::uint32_t total = 0, done = 0, successes = 0, infrastructure = 0, reran = 0;
  double rate_per_s = -1, eta_s = -1;  ///< -1: not known yet
  bool finished = false;
  std::vector<CellTally> cells;
};

class Board {
 public:
  explicit Board(Clock::duration forget_after = std::chrono::minutes(10)) : forget_after_(forget_after) {}

  void on_channel(const ChannelAnnounce& a, Clock::time_point now);
  /// A simulator worker whose announcements lost their liveliness: its channels are shown as lost until
  /// they announce themselves again or the worker comes back.
  void on_worker_lost(const std::string& worker, Clock::time_point now);
  /// Its announcements are alive again: its channels show what they last announced.
  void on_worker_back(const std::string& worker, Clock::time_point now);
  void on_live(const EpisodeLive& e, Clock::time_point now);
  void on_progress(const CampaignProgress& p, Clock::time_point now);

  /// {"channels": [{channel, host, state, episode_id, arm, cell, task, seed, step, budget_steps, capability,
  ///  decision, reason, outcome, evidence, age_s}], "campaigns": [{campaign, total, done, successes,
  ///  infrastructure, reran, rate_per_s, eta_s, finished, cells: [{arm, cell, successes, episodes, rate,
  ///  wilson_lo, wilson_hi}]}]}; state is idle, running, ended or lost; age_s the time since the row last
  /// changed. Channels in channel order, campaigns in the order first heard of.
  nlohmann::json snapshot(Clock::time_point now);

 private:
  struct Row {
    ChannelAnnounce announce;
    EpisodeLive live;
    bool announced = false, has_live = false, lost = false;
    Clock::time_point changed;
  };
  std::map<std::uint32_t, Row> channels_;
  std::vector<std::pair<CampaignProgress, Clock::time_point>> campaigns_;
  Clock::duration forget_after_;
};

}  // namespace dh::view
