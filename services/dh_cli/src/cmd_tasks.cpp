#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"

namespace dh::cli {

int cmd_tasks(bool json) {
  const auto suites = load_suites(paths::config_dir());
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [cell, s] : suites)
    for (const auto& [id, t] : s.tasks) {
      const std::string goal = goal_text(t.goal);
      if (json) {
        out.push_back({{"suite", cell}, {"base_suite", s.base_suite}, {"perturbation", s.perturbation},
                       {"task", id}, {"instruction", t.instruction}, {"goal", goal}, {"budget", t.budget_steps},
                       {"scene", t.scene_file.filename().string()}, {"swap", t.swap.text()},
                       {"modelled_on", s.modelled_on}, {"wordings", t.wordings}, {"pos", t.pos.empty() ? "" : t.pos.text()},
                       {"object", t.object.empty() ? "" : t.object.text()}});
      } else {
        std::cout << cell << "  " << id << "  budget " << t.budget_steps << "  " << t.instruction << "  [" << goal
                  << (t.swap.empty() ? "" : "; swap " + t.swap.text()) << (t.pos.empty() ? "" : "; " + t.pos.text())
                  << (t.object.empty() ? "" : "; " + t.object.text()) << "]\n";
        for (std::size_t w = 0; w < t.wordings.size(); ++w)
          std::cout << "      seed mod " << t.wordings.size() << " = " << w << ": " << t.wordings[w] << "\n";
      }
    }
  if (json) std::cout << out.dump(2) << "\n";
  return 0;
}

}  // namespace dh::cli
