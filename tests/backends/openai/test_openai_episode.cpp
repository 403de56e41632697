// One whole episode through `dh run` on deploy/local_openai.yaml (every service a process, DDS on
// loopback), its planner pointed at the scripted OpenAI-compatible server giving valid advisories.
#include <nlohmann/json.hpp>

#include "dh/common/evidence.hpp"
#include "fake_server.hpp"
#include "harness.hpp"

using namespace dh;

namespace {
/// Sets `--name value` in a service's arguments, replacing a value already there.
void set_arg(std::vector<std::string>& args, const std::string& name, const std::string& value) {
  auto it = std::find(args.begin(), args.end(), name);
  if (it != args.end() && std::next(it) != args.end())
    *std::next(it) = value;
  else
    args.insert(args.end(), {name, value});
}
}  // namespace

TEST(OpenAiEpisode, BowlOnPlateWithTheOpenAiPlanner) {
  itest::IsolatedEnv env;
  otest::FakeOpenAiServer server("valid");
  auto services = cli::load_launch_file(paths::home() / "deploy" / "local_openai.yaml");
  bool found = false;
  for (auto& s : services) {
    if (s.name != "planner") continue;
    found = true;
    EXPECT_NE(std::find(s.args.begin(), s.args.end(), "--endpoint"), s.args.end()) << "local_openai.yaml";
    EXPECT_NE(std::find(s.args.begin(), s.args.end(), "openai"), s.args.end()) << "local_openai.yaml";
    set_arg(s.args, "--endpoint", server.endpoint());
    set_arg(s.args, "--timeout-s", "5");  // within the governor's planner_timeout_ms (10 s)
  }
  ASSERT_TRUE(found) << "local_openai.yaml starts no planner";
  cli::Deployment d(services, paths::bin_dir(), env.runs / "logs");

  const auto dh = paths::bin_dir() / "dh";
  const auto [out, status] = itest::run_command(
      dh.string() + " run --suite goal --task 8 --seed 2 --json --ready-timeout-ms 20000 --timeout 120");
  ASSERT_EQ(status, 0) << out;
  const auto j = nlohmann::json::parse(out);
  EXPECT_TRUE(j["success"].get<bool>()) << out;
  const auto records = read_evidence(j["evidence"].get<std::string>());
  int advice = 0;
  for (const auto& r : records) {
    if (r["kind"] != "advice") continue;
    ++advice;
    EXPECT_EQ(r["backend"], "openai") << r.dump();
    EXPECT_FALSE(r["refused"].get<bool>()) << r.dump();
  }
  EXPECT_GE(advice, 1);
  EXPECT_GE(server.requests().size(), 1u);
  EXPECT_EQ(records.back()["outcome"], "success");
  // (A service may end at start by design, e.g. cap_vla_act without a trained policy; these may not.)
  for (const auto& name : d.exited())
    EXPECT_TRUE(name != "planner" && name != "governor" && name != "sim_worker") << name << " exited";
}
