#include "dh/planner/ports.hpp"

namespace dh::planner {

const Ports& ports() {
  static const Ports p{
      in_port<port::PlanRequest>("instruction, scene, the capabilities offered, the episode's history"),
      in_port<port::Announce>("each capability's argument roles, for the model's schema"),
      out_port<port::Advice>("the next step (and the rest), or a refusal with its reason"),
  };
  return p;
}

}  // namespace dh::planner
