// A campaign's progress line: bar, count, success rate, infrastructure losses, throughput and ETA. Pure
// logic: the caller passes the time and writes the string wherever it wants.
#pragma once

#include <chrono>
#include <cstddef>
#include <optional>
#include <string>

namespace dh::campaign {

class Progress {
 public:
  using Clock = std::chrono::steady_clock;

  /// `already_*` come from the database of a resumed campaign; the rate counts only this run's episodes,
  /// timed from `start`.
  Progress(std::size_t total, std::size_t already_done, std::size_t already_successes,
           std::size_t already_infrastructure, Clock::time_point start);

  void finished(bool success, bool infrastructure);

  /// e.g. "[#########.......]  123/800  success 61.0%  infra 1  2.3 ep/s  ETA 4m53s"; before the first
  /// episode of this run the rate is unknown: "-- ep/s  ETA --".
  std::string line(Clock::time_point now, unsigned bar_width = 16) const;
  /// line() for a terminal (redrawn in place: carriage return, erase to end of line) or a log (own line).
  std::string render(Clock::time_point now, bool terminal, unsigned bar_width = 16) const;

  /// This run's episodes per second, and the time the rest would take at that rate; none before the first.
  std::optional<double> rate_per_s(Clock::time_point now) const;
  std::optional<double> eta_s(Clock::time_point now) const;

  std::size_t total() const { return total_; }
  std::size_t done() const { return done_; }
  std::size_t successes() const { return successes_; }
  std::size_t infrastructure() const { return infrastructure_; }

 private:
  std::size_t total_, done_, successes_, infrastructure_;
  std::size_t done_this_run_ = 0;
  Clock::time_point start_;
};

/// Seconds as "53s", "4m53s" or "1h05m".
std::string format_duration(double seconds);

}  // namespace dh::campaign
