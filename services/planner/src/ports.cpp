#include "dh/planner/ports.hpp"

#include "dh/common/topics.hpp"

namespace dh::planner {

const Ports& ports() {
  using enum PortDirection;
  static const Ports p{
      {In, topics::kPlanRequest, "dh::msg::PlanRequest", dds::Qos::Planner,
       "instruction, scene, the capabilities offered, the episode's history"},
      {In, topics::kAnnounce, "dh::msg::CapabilityAnnounce", dds::Qos::Announce,
       "each capability's argument roles, for the model's schema"},
      {Out, topics::kAdvice, "dh::msg::Advice", dds::Qos::Planner, "the next step (and the rest), or a refusal with its reason"},
  };
  return p;
}

}  // namespace dh::planner
