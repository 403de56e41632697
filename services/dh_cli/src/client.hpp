// What a `dh` command sees of a deployment over DDS: simulator channels, announced capabilities,
// episode results; and how it sends episode requests.
#pragma once

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dh/cap/library_theta.hpp"
#include "dh/cli/launcher.hpp"
#include "dh/common/arms.hpp"
#include "dh/common/convert.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/gov/config.hpp"
#include "dh/common/dds.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "worker_writers.hpp"

namespace dh::cli {

class Client {
 public:
  explicit Client(dds::Participant& p);

  /// An idle channel once a governor and a simulator listen and `capability` is announced.
  std::optional<std::uint32_t> wait_ready(const std::string& capability, std::optional<std::uint32_t> want,
                                          std::chrono::milliseconds timeout);
  void request(const msg::EpisodeRequest& r) { request_.write(r); }
  std::optional<msg::EpisodeResult> wait_result(const std::string& episode, std::chrono::milliseconds timeout);

  /// Channel announcements and results received since the last call, in arrival order.
  struct News {
    std::vector<msg::ChannelStatus> channels;
    std::vector<msg::EpisodeResult> results;
    std::vector<std::string> lost_workers;  ///< workers whose channel announcements lost liveliness
    std::vector<std::string> returned_workers;  ///< ... and whose announcements are alive again
  };
  News take_news();

 private:
  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::uint32_t, bool> idle_;
  std::set<std::string> capabilities_;
  std::map<std::string, msg::EpisodeResult> results_seen_;
  WorkerWriters workers_;
  News news_;
  dds::Writer<msg::EpisodeRequestPubSubType> request_;
  dds::Reader<msg::ChannelStatusPubSubType> channels_;
  dds::Reader<msg::CapabilityAnnouncePubSubType> caps_;
  dds::Reader<msg::EpisodeResultPubSubType> results_;
};

/// The rates of planner-error profile `name` of configs/planner_errors.yaml; none for "".
inline PlannerErrorRates planner_errors(const std::string& name) {
  return name.empty() ? PlannerErrorRates{} : load_planner_errors(paths::config_dir() / "planner_errors.yaml", name);
}

/// Puts the library an episode runs into its request: version, θ and cost by capability.
inline void set_library(msg::EpisodeRequest& r, const cap::LibraryTheta& lib) {
  r.library_version(lib.version);
  std::vector<msg::CapabilityTheta> theta;
  for (const auto& [capability, params] : lib.theta) {
    msg::CapabilityTheta c;
    c.capability(capability);
    c.parameters(convert::to_msg(params));
    if (const auto cost = lib.cost_steps.find(capability); cost != lib.cost_steps.end()) c.cost_steps(cost->second);
    theta.push_back(std::move(c));
  }
  r.library(std::move(theta));
}

/// What each of `arms` means in configs/governor.yaml (decision period, grounding, perception limits), read
/// once; throws ConfigError for an unknown arm.
inline std::map<std::string, gov::GovernorConfig> arm_settings(const std::filesystem::path& config_dir,
                                                               const std::vector<std::string>& arms) {
  const gov::GovernorConfig base = gov::load_config(config_dir / "governor.yaml");
  const auto defined = load_arms(config_dir / "governor.yaml");
  std::map<std::string, gov::GovernorConfig> out;
  for (const auto& a : arms) out[a] = gov::for_arm(base, find_arm(defined, a));
  return out;
}

/// Puts an episode's settings (its arm's, from arm_settings) into its request. The governor and the
/// perception service take them from the request, so they need not read the arms.
inline void set_settings(msg::EpisodeRequest& r, const gov::GovernorConfig& c) {
  r.decision_period_steps(c.decision_period);
  r.grounding(c.perception ? "perception" : "state");
  r.perception(convert::to_msg(c.perception_limits));
}

/// The task's goal resolved against its scene's description, as the governor's verdict from perception
/// judges it; throws std::invalid_argument naming a term the scene cannot resolve.
std::vector<msg::GoalTerm> goal_terms(const TaskDef& task);

/// The capability a deployment must announce to be ready for `arms`: vla_act when every arm is the bare
/// policy, else pick_place (the first one the embedded planner needs).
inline std::string ready_capability(const std::vector<std::string>& arms) {
  for (const auto& a : arms)
    if (a != "bare") return "pick_place";
  return "vla_act";
}

/// Waits `ready` for a live deployment with an idle channel (`want`, or any) that announces `capability`;
/// when none answers, starts
/// `launch_file` (default deploy/local.yaml) and waits up to 20 s. Returns the channel or nullopt (with an
/// error on stderr naming the logs); `local` holds a deployment this call started.
std::optional<std::uint32_t> ensure_deployment(Client& client, const std::string& capability,
                                               std::optional<std::uint32_t> want, const std::string& launch_file,
                                               std::chrono::milliseconds ready, bool quiet,
                                               std::unique_ptr<Deployment>& local);

}  // namespace dh::cli
