#include "dh/campaign/progress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dh::campaign {

namespace {
std::string fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
}  // namespace

Progress::Progress(std::size_t total, std::size_t already_done, std::size_t already_successes,
                   std::size_t already_infrastructure, Clock::time_point start)
    : total_(total),
      done_(already_done),
      successes_(already_successes),
      infrastructure_(already_infrastructure),
      start_(start) {}

void Progress::finished(bool success, bool infrastructure) {
  ++done_;
  ++done_this_run_;
  successes_ += success;
  infrastructure_ += infrastructure;
}

std::string format_duration(double seconds) {
  const auto s = static_cast<long long>(std::llround(std::max(0.0, seconds)));
  char buf[32];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%llds", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%lldm%02llds", s / 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", s / 3600, s % 3600 / 60);
  return buf;
}

std::string Progress::line(Clock::time_point now, unsigned bar_width) const {
  const std::size_t filled =
      total_ == 0 ? bar_width : std::min<std::size_t>(bar_width, done_ * bar_width / total_);
  std::string out = "[" + std::string(filled, '#') + std::string(bar_width - filled, '.') + "]  ";

  const std::string total = std::to_string(total_), done = std::to_string(done_);
  out += std::string(total.size() > done.size() ? total.size() - done.size() : 0, ' ') + done + "/" + total;

  out += "  success " + (done_ ? fixed(100.0 * successes_ / done_, 1) + "%" : std::string("--"));
  out += "  infra " + std::to_string(infrastructure_);

  const auto rate = rate_per_s(now);
  if (!rate) return out + "  -- ep/s  ETA --";
  // Two significant figures at most, so slow campaigns (one episode a minute) do not show "0.0 ep/s".
  out += "  " + fixed(*rate, *rate >= 10 ? 0 : *rate >= 1 ? 1 : 2) + " ep/s";
  return out + "  ETA " + format_duration(*eta_s(now));
}

std::optional<double> Progress::rate_per_s(Clock::time_point now) const {
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (done_this_run_ == 0 || elapsed <= 0) return std::nullopt;
  return done_this_run_ / elapsed;
}

std::optional<double> Progress::eta_s(Clock::time_point now) const {
  const auto rate = rate_per_s(now);
  if (!rate) return std::nullopt;
  return static_cast<double>(total_ > done_ ? total_ - done_ : 0) / *rate;
}

std::string Progress::render(Clock::time_point now, bool terminal, unsigned bar_width) const {
  return terminal ? "\r" + line(now, bar_width) + "\x1b[K" : line(now, bar_width) + "\n";
}

}  // namespace dh::campaign
