// The episode page's data from an evidence file: the request and the outcome, and on the step axis what
// the governor, the planner and the capabilities recorded; a file that is missing or not a governor's is
// named.
#include <gtest/gtest.h>

#include <fstream>

#include <unistd.h>

#include "dh/view/timeline.hpp"

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

fs::path write(const std::string& name, const std::vector<json>& records) {
  const fs::path p = fs::temp_directory_path() / ("dh_timeline_" + std::to_string(getpid()) + "_" + name);
  std::ofstream out(p);
  for (const auto& r : records) out << r.dump() << "\n";
  return p;
}

}  // namespace

TEST(Timeline, FigureThreeInMiniatureOnTheStepAxis) {
  const fs::path p = write("ok.jsonl", {
      {{"kind", "episode_request"}, {"arm", "full"}, {"cell", "goal-swap"}, {"suite", "goal-swap"}, {"task", 5}, {"seed", 21}},
      {{"kind", "episode_start"}, {"episode_id", "goal-swap/5/21#1"}, {"instruction", "push the plate"}, {"budget_steps", 300}},
      {{"kind", "observation"}, {"step", 0}},
      {{"kind", "advice"}, {"step", 0}, {"capability", "push"}, {"args", {{"object", "plate"}}}, {"done", false}, {"refused", false}},
      {{"kind", "grounding"}, {"step", 0}, {"result", "grounded"}, {"command_id", "c0"}, {"capability", "push"}, {"theta", {{"contact_fraction", 0.6}}}},
      {{"kind", "dispatch"}, {"step", 0}, {"command_id", "c0"}, {"instance", "push@a"}, {"budget_steps", 280}},
      {{"kind", "command_status"}, {"step", 0}, {"command_id", "c0"}, {"state", "accepted"}},
      {{"kind", "command_status"}, {"step", 0}, {"command_id", "c0"}, {"state", "refused"}, {"reason", "the jaw is too narrow"}},
      {{"kind", "decision"}, {"step", 0}, {"decision", "substitute"}, {"reason", "command refused"}, {"capability", "push"}},
      {{"kind", "decision"}, {"step", 10}, {"decision", "continue"}},
      {{"kind", "safety_hold"}, {"step", 12}},
      {{"kind", "verdict_event"}, {"step", 218}, {"predicate", "On(plate, stove_front_region)"}, {"value", true}},
      {{"kind", "episode_end"}, {"step", 220}, {"outcome", "success"}, {"success", true}, {"latched", true}, {"verdict_step", 218}, {"reason", "latched"}},
  });
  const json t = dh::view::episode_timeline(p, {});
  EXPECT_EQ(t["episode_id"], "goal-swap/5/21#1");
  EXPECT_EQ(t["cell"], "goal-swap");
  EXPECT_EQ(t["end_step"], 220);
  EXPECT_EQ(t["verdict_step"], 218);
  EXPECT_EQ(t["safety_holds"], 1);
  EXPECT_TRUE(t["attribution"].is_null()) << "a success has none";
  std::vector<std::string> kinds;
  for (const auto& e : t["events"]) kinds.push_back(e["kind"]);
  EXPECT_EQ(kinds, (std::vector<std::string>{"advice", "grounding", "dispatch", "refusal", "decision", "verdict", "end"}));
  EXPECT_EQ(t["events"][1]["theta"]["contact_fraction"], 0.6);
  EXPECT_EQ(t["events"][2]["capability"], "push");
  EXPECT_EQ(t["events"][3]["reason"], "the jaw is too narrow");
  fs::remove(p);
}

TEST(Timeline, AMissingOrForeignFileIsNamed) {
  const auto message = [](const fs::path& p) {
    try {
      dh::view::episode_timeline(p, {});
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(message("/nonexistent/ep.jsonl").find("/nonexistent/ep.jsonl: no such evidence file"), std::string::npos);
  const fs::path foreign = write("foreign.jsonl", {{{"kind", "something"}}});
  EXPECT_NE(message(foreign).find("no episode_start record"), std::string::npos) << message(foreign);
  fs::remove(foreign);
}
