// The self-evolution commands: `dh probe` and `dh library perturb`.
#include <iostream>

#include "commands.hpp"
#include "dh/common/paths.hpp"
#include "dh/evo/perturb.hpp"
#include "dh/evo/probe.hpp"

namespace dh::cli {

int cmd_probe(const ProbeArgs& a) {
  evo::ProbeReport r;
  try {
    r = evo::probe(a.evidence, {paths::config_dir(), a.library, a.command});
  } catch (const std::runtime_error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  const int code = r.effect_held ? 0 : 3;
  if (a.json) {
    std::cout << evo::to_json(r).dump() << "\n";
    return code;
  }
  std::cout << r.episode_id << " command " << a.command << " (" << r.command_id << ", " << r.capability << ") under "
            << (r.library == "recorded" ? "the recorded θ" : "library " + r.library) << ", from step " << r.from_step
            << ", budget " << r.budget_steps << " steps\n";
  std::cout << "  ended " << r.state << " at step " << r.end_step
            << (r.failure != "none" ? " (" + r.failure + (r.stage.empty() ? "" : " in " + r.stage) + ")" : "")
            << (r.reason.empty() ? "" : ": " + r.reason) << "\n";
  std::cout << "  effect " << r.effect << ": " << (r.effect_held ? "held" : "did not hold") << "\n";
  if (r.recorded)
    std::cout << "  recorded: " << r.recorded->state << " at step " << r.recorded->step
              << (r.recorded->failure != "none" ? " (" + r.recorded->failure + ")" : "") << "\n";
  else
    std::cout << "  recorded: the governor moved on before the command ended\n";
  std::cout << "  " << r.steps_compared << " step(s) compared with the step log: "
            << (r.first_divergence ? "first differs at step " + std::to_string(r.first_divergence->step) + ", " +
                                         r.first_divergence->body + " " + r.first_divergence->quantity
                                   : std::string("identical"))
            << (r.reproduces ? "; the recorded command reproduced bit for bit" : "") << "\n";
  return code;
}

int cmd_library_perturb(const std::string& from, std::uint64_t seed, const std::string& out, bool json) {
  const evo::PerturbedLibrary p = evo::perturb_library(from, seed, out);
  if (json) {
    std::cout << nlohmann::json{{"version", p.version}, {"out", out}, {"seed", seed}, {"theta", p.theta}}.dump() << "\n";
    return 0;
  }
  std::size_t n = 0;
  for (const auto& [capability, theta] : p.theta) n += theta.size();
  std::cout << "library " << p.version << " written to " << out << ": " << n << " parameters of " << p.theta.size()
            << " capabilities drawn within their ranges (seed " << seed << ")\n";
  return 0;
}

}  // namespace dh::cli
