#include "dh/view/board.hpp"

#include <algorithm>

#include "dh/common/stats.hpp"

namespace dh::view {

using nlohmann::json;

void Board::on_channel(const ChannelAnnounce& a, Clock::time_point now) {
  Row& r = channels_[a.channel];
  const bool changed = !r.announced || r.lost || r.announce.running != a.running ||
                       r.announce.episode_id != a.episode_id || r.announce.worker != a.worker;
  r.announce = a;
  r.announced = true;
  r.lost = false;
  if (changed) r.changed = now;
}

void Board::on_worker_lost(const std::string& worker, Clock::time_point now) {
  for (auto& [id, r] : channels_)
    if (r.announced && r.announce.worker == worker && !r.lost) {
      r.lost = true;
      r.changed = now;
    }
}

void Board::on_worker_back(const std::string& worker, Clock::time_point now) {
  for (auto& [id, r] : channels_)
    if (r.announced && r.announce.worker == worker && r.lost) {
      r.lost = false;
      r.changed = now;
    }
}

void Board::on_live(const EpisodeLive& e, Clock::time_point now) {
  Row& r = channels_[e.channel];
  // A sample of an older episode than the one shown (a late one of a finished episode) is not news.
  if (r.has_live && r.live.episode_id == e.episode_id && r.live.ended && !e.ended) return;
  r.live = e;
  r.has_live = true;
  r.changed = now;
}

void Board::on_progress(const CampaignProgress& p, Clock::time_point now) {
  for (auto& [c, heard] : campaigns_)
    if (c.campaign == p.campaign) {
      c = p;
      heard = now;
      return;
    }
  campaigns_.emplace_back(p, now);
}

json Board::snapshot(Clock::time_point now) {
  std::erase_if(campaigns_, [&](const auto& c) { return now - c.second > forget_after_; });
  const auto seconds = [&](Clock::time_point t) { return std::chrono::duration<double>(now - t).count(); };
  json channels = json::array();
  for (const auto& [id, r] : channels_) {
    // The governor's view of the episode counts when it is of the episode the channel runs or ran last.
    const bool running = r.announced ? r.announce.running : r.has_live && !r.live.ended;
    const std::string state = r.lost ? "lost" : running ? "running" : r.has_live && r.live.ended ? "ended" : "idle";
    json row{{"channel", id}, {"host", r.announce.worker}, {"state", state}, {"age_s", seconds(r.changed)}};
    const EpisodeLive& e = r.live;
    if (r.has_live) {
      row.update({{"episode_id", e.episode_id}, {"arm", e.arm}, {"cell", e.cell}, {"task", e.task}, {"seed", e.seed},
                  {"step", e.step}, {"budget_steps", e.budget_steps}, {"capability", e.capability},
                  {"decision", e.decision}, {"reason", e.reason}, {"outcome", e.ended ? e.outcome : ""},
                  {"evidence", e.evidence}});
    } else {
      row["episode_id"] = r.announce.episode_id;
    }
    channels.push_back(std::move(row));
  }
  json campaigns = json::array();
  for (const auto& [c, heard] : campaigns_) {
    json cells = json::array();
    for (const auto& t : c.cells) {
      const stats::Interval w = stats::wilson(t.successes, t.episodes);
      cells.push_back({{"arm", t.arm}, {"cell", t.cell}, {"successes", t.successes}, {"episodes", t.episodes},
                       {"rate", t.episodes ? json(w.point) : json(nullptr)}, {"wilson_lo", w.lo}, {"wilson_hi", w.hi}});
    }
    campaigns.push_back({{"campaign", c.campaign}, {"total", c.total}, {"done", c.done}, {"successes", c.successes},
                         {"infrastructure", c.infrastructure}, {"reran", c.reran},
                         {"rate_per_s", c.rate_per_s < 0 ? json(nullptr) : json(c.rate_per_s)},
                         {"eta_s", c.eta_s < 0 ? json(nullptr) : json(c.eta_s)}, {"finished", c.finished},
                         {"cells", cells}, {"age_s", seconds(heard)}});
  }
  return {{"channels", channels}, {"campaigns", campaigns}};
}

}  // namespace dh::view
