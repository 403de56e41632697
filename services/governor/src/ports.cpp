#include "dh/gov/ports.hpp"

#include "dh/common/topics.hpp"

namespace dh::gov {

const Ports& ports() {
  using enum PortDirection;
  static const Ports p{
      {In, topics::kEpisodeRequest, "dh::msg::EpisodeRequest", dds::Qos::Episode,
       "starts a channel's episode: arm, library θ and version, settings"},
      {In, topics::kObservation, "dh::msg::Observation", dds::Qos::Observation, "every step; decisions every period"},
      {In, topics::kAdvice, "dh::msg::Advice", dds::Qos::Planner, "the slow brain's next step"},
      {In, topics::kCommandStatus, "dh::msg::CommandStatus", dds::Qos::Status, "the running command's state"},
      {In, topics::kAnnounce, "dh::msg::CapabilityAnnounce", dds::Qos::Announce,
       "capability instances, draining, liveliness (a lost lease: the instance is lost)"},
      {In, topics::kVerdict, "dh::msg::Verdict", dds::Qos::Verdict, "the task predicate's changes, latched"},
      {In, topics::kSeamEvent, "dh::msg::SeamEvent", dds::Qos::Status, "the seam's refusals and corrections"},
      {In, topics::kSceneEstimate, "dh::msg::SceneEstimate", dds::Qos::Observation,
       "estimates, for episodes grounded in perception"},
      {In, topics::kCommand, "dh::msg::Command", dds::Qos::Command, "commands it did not write: recorded as foreign"},
      {Out, topics::kPlanRequest, "dh::msg::PlanRequest", dds::Qos::Planner, "asks the slow brain"},
      {Out, topics::kCommand, "dh::msg::Command", dds::Qos::Command, "START and CANCEL to one instance"},
      {Out, topics::kLease, "dh::msg::Lease", dds::Qos::Lease, "the running command's lease, rewritten every 250 ms"},
      {Out, topics::kEpisodeResult, "dh::msg::EpisodeResult", dds::Qos::Episode, "the outcome, typed"},
      {Out, topics::kEvidence, "dh::msg::EpisodeLive", dds::Qos::Episode,
       "each channel's episode as its evidence stands: step, capability, last decision (live views)"},
  };
  return p;
}

}  // namespace dh::gov
