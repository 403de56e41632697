#include "dh/gov/config.hpp"

#include "dh/common/config.hpp"

namespace dh::gov {

GovernorConfig load_config(const std::filesystem::path& file) {
  const ConfigNode c = ConfigNode::load_file(file);
  GovernorConfig g;
  g.decision_period = c.get<unsigned>("decision_period_steps");
  if (g.decision_period == 0) c.fail("decision_period_steps", "must be at least 1");
  g.limits.max_retries = c.get<int>("max_retries");
  g.limits.max_replans = c.get<int>("max_replans");
  g.limits.stagnation_decisions = c.get<unsigned>("stagnation_decisions");
  g.max_refusals = c.get<int>("max_refusals_in_row");
  if (g.max_refusals < 1) c.fail("max_refusals_in_row", "must be at least 1 (it bounds refusals in a row)");
  g.max_recoveries = c.get<int>("max_recoveries");
  if (c.has("substitutes")) {
    const ConfigNode subs = c.child("substitutes");
    for (const auto& k : subs.keys()) g.substitutes[k] = subs.get<std::vector<std::string>>(k);
  }
  g.planner_timeout = std::chrono::milliseconds(c.get<unsigned>("planner_timeout_ms"));
  g.ack_timeout = std::chrono::milliseconds(c.get<unsigned>("ack_timeout_ms"));
  g.first_observation_timeout = std::chrono::milliseconds(c.get<unsigned>("first_observation_timeout_ms"));
  g.step_stall_timeout = std::chrono::milliseconds(c.get<unsigned>("step_stall_timeout_ms"));
  if (c.has("perception")) {
    g.perception_limits = perception_limits(c.child("perception"));
  }
  g.verdict_frames = c.get<unsigned>("verdict_frames");
  if (g.verdict_frames == 0) c.fail("verdict_frames", "must be at least 1 (one frame alone would latch)");
  g.verdict_wait_frames = c.get<unsigned>("verdict_wait_frames");
  if (g.verdict_wait_frames < g.verdict_frames)
    c.fail("verdict_wait_frames", "must be at least verdict_frames (fewer frames could never change the verdict)");
  g.verdict_wait = std::chrono::milliseconds(c.get<unsigned>("verdict_wait_ms"));
  return g;
}

/// The governor configuration of one episode: the defaults with the arm's mode and masked capabilities.
GovernorConfig for_arm(GovernorConfig g, const ArmSpec& arm) {
  g.mode = arm.mode == "static" ? ExecutorMode::Static
           : arm.mode == "seq"  ? ExecutorMode::Seq
           : arm.mode == "bare" ? ExecutorMode::Bare
                                : ExecutorMode::Full;
  g.masked = {arm.masked.begin(), arm.masked.end()};
  g.latch = arm.latch;
  if (arm.grounding == "perception") g.perception = g.perception_limits;
  return g;
}

std::set<std::string> needed_capabilities(const GovernorConfig& episode, const EpisodeSpec& spec) {
  std::set<std::string> needed;
  for (const auto& [capability, theta] : spec.library)
    if (!episode.masked.count(capability) && (episode.mode != ExecutorMode::Bare || capability == "vla_act"))
      needed.insert(capability);
  return needed;
}

GovernorConfig for_request(GovernorConfig g, const EpisodeSpec& spec) {
  if (spec.decision_period) g.decision_period = *spec.decision_period;
  if (g.decision_period == 0) throw ConfigError("episode " + spec.episode_id + ": a decision period of 0 steps");
  if (spec.perception) g.perception_limits = *spec.perception;
  if (spec.grounding) {
    if (*spec.grounding == "perception")
      g.perception = g.perception_limits;
    else if (*spec.grounding == "state")
      g.perception.reset();
    else
      throw ConfigError("episode " + spec.episode_id + ": grounding '" + *spec.grounding +
                        "' (expected state or perception)");
  } else if (g.perception) {
    // The perception service renders only for requests that say so: without it nothing would be seen.
    throw ConfigError("episode " + spec.episode_id + ": arm '" + spec.arm +
                      "' grounds from perception, but the request does not say grounding: perception (the "
                      "perception service would not look; dh run and dh campaign set it)");
  }
  if (!spec.verifier)
    throw ConfigError("episode " + spec.episode_id + ": the request's verifier code is not one this governor knows "
                      "(oracle, perception); is the client newer than the governor?");
  g.verifier = *spec.verifier;
  if (g.verifier == Verifier::Perception && !g.perception)
    throw ConfigError("episode " + spec.episode_id + ": verifier perception needs an arm that grounds from perception "
                      "(e.g. full-perception), so that the perception service looks; arm '" + spec.arm + "' does not");
  if (g.verifier == Verifier::Perception && spec.goal.empty())
    throw ConfigError("episode " + spec.episode_id + ": verifier perception, but the request names no goal terms to judge");
  return g;
}

}  // namespace dh::gov
