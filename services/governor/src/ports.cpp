#include "dh/gov/ports.hpp"

namespace dh::gov {

const Ports& ports() {
  static const Ports p{
      in_port<port::EpisodeRequest>("starts a channel's episode: arm, library θ and version, settings"),
      in_port<port::Observation>("every step; decisions every period"),
      in_port<port::Advice>("the slow brain's next step"),
      in_port<port::CommandStatus>("the running command's state"),
      in_port<port::Announce>(
          "capability instances, draining, liveliness (a lost lease: the instance is lost)"),
      in_port<port::Verdict>("the task predicate's changes, latched"),
      in_port<port::SeamEvent>("the seam's refusals and corrections"),
      in_port<port::SceneEstimate>("estimates, for episodes grounded in perception"),
      in_port<port::Command>("commands it did not write: recorded as foreign"),
      out_port<port::PlanRequest>("asks the slow brain"),
      out_port<port::Command>("START and CANCEL to one instance"),
      out_port<port::Lease>("the running command's lease, rewritten every 250 ms"),
      out_port<port::EpisodeResult>("the outcome, typed"),
      out_port<port::Evidence>(
          "each channel's episode as its evidence stands: step, capability, last decision (live views)"),
  };
  return p;
}

}  // namespace dh::gov
