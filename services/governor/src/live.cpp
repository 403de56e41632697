#include "dh/gov/live.hpp"

#include <algorithm>

namespace dh::gov {

LiveTracker::LiveTracker(std::uint32_t channel, std::string episode_id, std::filesystem::path evidence) {
  state_.channel = channel;
  state_.episode_id = std::move(episode_id);
  state_.evidence = std::move(evidence);
}

void LiveTracker::record(const std::string& kind, const nlohmann::json& f) {
  const auto text = [&](const char* key) { return f.contains(key) && f[key].is_string() ? f[key].get<std::string>() : std::string(); };
  if (f.contains("step") && f["step"].is_number_unsigned()) state_.step = f["step"].get<std::uint32_t>();
  if (kind == "observation") return;  // news only by the step it moved on to
  if (kind == "episode_request") {
    state_.arm = text("arm");
    state_.cell = text("cell");
    state_.task = f.value("task", 0u);
    state_.seed = f.value("seed", std::uint64_t{0});
  } else if (kind == "episode_start") {
    state_.episode_id = text("episode_id");
    state_.budget_steps = f.value("budget_steps", 0u);
    period_ = std::max(1u, f.value("decision_period", 10u));
  } else if (kind == "grounding" && text("result") == "grounded") {
    capability_of_[text("command_id")] = text("capability");
  } else if (kind == "dispatch") {
    state_.capability = capability_of_[text("command_id")];
  } else if (kind == "decision") {
    state_.decision = text("decision");
    state_.reason = text("reason");
    if (!text("capability").empty()) state_.capability = text("capability");
  } else if (kind == "refusal") {
    state_.decision = "refused (" + text("refusal") + ")";
    state_.reason = text("reason");
  } else if (kind == "episode_end" || kind == "episode_rejected") {
    state_.ended = true;
    state_.outcome = kind == "episode_rejected" ? "rejected" : text("outcome");
    state_.reason = text("reason");
  } else {
    return;
  }
  news_ = true;
}

std::optional<LiveState> LiveTracker::take() {
  if (!news_ && state_.step < taken_step_ + period_) return std::nullopt;
  news_ = false;
  taken_step_ = state_.step;
  return state_;
}

}  // namespace dh::gov
