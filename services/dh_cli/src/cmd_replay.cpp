#include <iostream>

#include "commands.hpp"
#include "dh/common/paths.hpp"
#include "dh/inproc/replay.hpp"

namespace dh::cli {

int cmd_replay(const ReplayArgs& a) {
  inproc::ReplayOptions o{paths::config_dir(), a.library, a.from_command, a.allow_drift, {}};
  inproc::ReplayReport r;
  try {
    r = inproc::replay(a.evidence, o);
  } catch (const inproc::FingerprintMismatch& e) {
    std::cerr << "error: " << a.evidence << ": " << e.what() << "\n";
    return 4;
  } catch (const std::runtime_error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  if (a.json) {
    std::cout << inproc::to_json(r).dump() << "\n";
    return r.identical ? 0 : 3;
  }
  for (const auto& d : r.drift) std::cout << "drift (allowed): " << d << "\n";
  for (const auto& c : r.recorded_only) std::cout << "from the record only: " << c << "\n";
  std::cout << r.episode_id << ": " << r.steps << " of " << r.recorded_steps << " steps replayed"
            << (a.from_command ? " (command " + std::to_string(*a.from_command) + " of " + std::to_string(r.commands) +
                                     ", from the state recorded at step " + std::to_string(r.from_step) + ")"
                               : std::string())
            << ", " << r.actions_compared << " skill actions and " << r.states_checked << " whole states compared\n";
  if (r.identical) {
    std::cout << "identical: every state digest" << (r.actions_compared ? ", action" : "")
              << (a.from_command ? "" : " and verdict") << " as recorded\n";
    return 0;
  }
  if (r.first_divergence)
    std::cout << "diverged at step " << r.first_divergence->step << ": " << r.first_divergence->body << " "
              << r.first_divergence->quantity << " (" << r.divergent_steps << " divergent step(s))\n";
  if (!r.verdicts_identical) std::cout << "diverged: the predicate changed at other steps than recorded\n";
  return 3;
}

}  // namespace dh::cli
