// vla_act over real processes: `dh train-policy` writes a weight file, cap_vla_act serves it on DDS, the
// bare arm hands it whole episodes, and the no-analytic arm hands it the segments its masked skills
// would have done. A missing weight file ends the process with its reason.
#include <fstream>

#include <nlohmann/json.hpp>

#include "dh/common/evidence.hpp"
#include "harness.hpp"

using namespace dh;
using nlohmann::json;

namespace {
// A small training run: ten goal demonstrations, three epochs (fast; its success is not the point).
std::filesystem::path tiny_policy_config(const std::filesystem::path& dir) {
  const auto file = dir / "policy_tiny.yaml";
  std::ifstream in(paths::config_dir() / "policy.yaml");
  std::ofstream out(file);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("  goal: {seeds:", 0) == 0) line = "  goal: {seeds: \"1000-1000\"}";
    if (line.rfind("  long: {seeds:", 0) == 0) continue;
    if (line.rfind("  hidden:", 0) == 0) line = "  hidden: [32]";
    out << line << "\n";
  }
  return file;
}

int count_kind(const std::vector<json>& records, const std::string& kind, const std::string& key = "",
               const std::string& value = "") {
  int n = 0;
  for (const auto& r : records)
    n += r.value("kind", "") == kind && (key.empty() || r.value(key, "") == value);
  return n;
}
}  // namespace

TEST(VlaAct, TrainedPolicyServesTheBareArmAndTheSegmentsOfTheNoAnalyticArm) {
  itest::IsolatedEnv env;
  const auto dh = paths::bin_dir() / "dh";
  const auto [train_out, train_status] = itest::run_command(
      dh.string() + " train-policy --epochs 3 --config " + tiny_policy_config(env.runs).string() + " 2>&1");
  ASSERT_EQ(train_status, 0) << train_out;
  const auto weights = env.runs / "policy" / "vla_mlp.dhp";
  ASSERT_TRUE(std::filesystem::exists(weights)) << train_out;
  std::ifstream curve(env.runs / "policy" / "loss.csv");
  int lines = 0;
  for (std::string l; std::getline(curve, l);) ++lines;
  EXPECT_EQ(lines, 4) << "a header and one line per epoch";
  const json manifest = json::parse(std::ifstream(env.runs / "policy" / "train.json"));
  EXPECT_EQ(manifest["sha256"].get<std::string>().size(), 64u);

  cli::Deployment d({itest::service("sim_worker"), itest::service("governor"), itest::service("planner"),
                     itest::service("cap_pick_place"), itest::service("cap_push"), itest::service("cap_recovery"),
                     itest::service("cap_vla_act")},
                    paths::bin_dir(), env.runs / "logs");
  const auto [out, status] = itest::run_command(dh.string() +
                                                " run --suite goal --task 8 --seed 3 --arm bare --json --ready-timeout-ms 20000");
  ASSERT_EQ(status, 0) << out;
  auto j = json::parse(out);
  EXPECT_TRUE(j["outcome"] == "success" || j["outcome"] == "budget_exhausted") << out;
  auto records = read_evidence(j["evidence"].get<std::string>());
  EXPECT_EQ(count_kind(records, "plan_request"), 0) << "the bare arm has no planner";
  ASSERT_GE(count_kind(records, "grounding", "capability", "vla_act"), 1);
  for (const auto& r : records)
    if (r.value("kind", "") == "grounding") {
      EXPECT_EQ(r["capability"], "vla_act");
      EXPECT_EQ(r["args"]["instruction"], "put the bowl on the plate");
    }
  EXPECT_GT(j["steps"].get<int>(), 100) << "the policy acted for the episode";

  const auto [out2, status2] = itest::run_command(dh.string() + " run --suite goal --task 8 --seed 3 --arm no-analytic --json");
  ASSERT_EQ(status2, 0) << out2;
  j = json::parse(out2);
  records = read_evidence(j["evidence"].get<std::string>());
  EXPECT_GE(count_kind(records, "advice", "capability", "vla_act"), 1) << "masked pick_place: the planner hands over";
  EXPECT_GE(count_kind(records, "grounding", "capability", "vla_act"), 1);
  EXPECT_EQ(count_kind(records, "grounding", "capability", "pick_place"), 0);
  EXPECT_TRUE(d.exited().empty()) << "a service exited";
}

TEST(VlaAct, AMissingWeightFileEndsTheProcessWithItsReason) {
  itest::IsolatedEnv env;
  const auto [out, status] = itest::run_command((paths::bin_dir() / "cap_vla_act").string() + " --weights " +
                                                (env.runs / "nowhere.dhp").string() + " 2>&1");
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("nowhere.dhp: no such file; train one with `dh train-policy`"), std::string::npos) << out;
}
