#include "dh/rtde/oracle_verdict.hpp"

#include <mujoco/mujoco.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace dh::rtde {

OracleVerdict::OracleVerdict(SimulatedUr& arm, const sim::SceneSpec& scene, const TaskDef& task,
                             std::filesystem::path file)
    : eval_(arm.mj_model(), scene, task.goal), goal_(goal_text(task.goal)), file_(std::move(file)) {}

bool OracleVerdict::judge(SimulatedUr& arm) {
  const bool now = eval_.holds(arm.mj_data());
  time_s_ = arm.mj_data()->time;
  const bool changed = !judged_ || now != holds_;
  judged_ = true;
  holds_ = now;
  return changed;
}

void OracleVerdict::write() const {
  const auto tmp = file_.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << nlohmann::json{{"goal", goal_}, {"holds", holds_}, {"time_s", time_s_}}.dump() << "\n";
    if (!out) throw std::runtime_error("cannot write the oracle's verdict to " + tmp);
  }
  std::filesystem::rename(tmp, file_);
}

}  // namespace dh::rtde
