// Episodes recorded over DDS (every process of campaign_local.yaml: two simulator workers, the governor,
// the planner, every capability family, perception) replay in process bit for bit: every state digest,
// every skill action and every verdict as recorded, also from the state recorded at a command's start. Their
// commands, probed from the state recorded at their start under the recorded θ (every failed one and one
// other per episode), run as recorded, and so does the rest of each episode from there. And
// `dh replay` refuses a changed θ.
#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "campaign_helpers.hpp"
#include "dh/evo/probe.hpp"
#include "dh/inproc/replay.hpp"
#include "harness.hpp"

using namespace dh;

namespace {
// Five arms (vla_act has no weights in a fresh runs folder, so bare and the policy are not here) x the six
// cells x two tasks: 60 episodes.
constexpr const char* kArms = "full,static,seq,no-recovery,full-perception";
constexpr const char* kCells = "goal,goal-task,goal-swap,long,long-task,long-swap";
}  // namespace

TEST(ReplayE2E, EpisodesRecordedOverDdsReplayBitForBit) {
  itest::IsolatedEnv env;
  const std::string dh = (paths::bin_dir() / "dh").string();
  const auto rows = itest::local_campaign(env, std::string("--arms ") + kArms + " --cells " + kCells + " --tasks 0,7 --seeds 21");
  ASSERT_EQ(rows.size(), 60u);

  std::set<std::string> arms, cells;
  std::size_t identical = 0, compared = 0, resumed = 0, resumed_mid = 0, probed = 0, probes_reproduce = 0,
              failures_reproduce = 0, rests_reproduce = 0;
  for (const auto& row : rows) {
    ASSERT_FALSE(row.infrastructure) << row.episode_id << ": " << row.reason;
    const auto r = inproc::replay(row.evidence_path, {paths::config_dir(), {}, std::nullopt, false, {}});
    EXPECT_TRUE(r.identical) << row.evidence_path << ": first divergence "
                             << (r.first_divergence ? std::to_string(r.first_divergence->step) + " " +
                                                          r.first_divergence->body + " " + r.first_divergence->quantity
                                                    : "none")
                             << (r.verdicts_identical ? "" : "; verdicts differ");
    EXPECT_EQ(r.recorded_steps, row.steps) << row.evidence_path;
    identical += r.identical;
    compared += r.actions_compared;
    // Perception-grounded skills act again on the estimates the governor recorded.
    EXPECT_EQ(r.actions_compared, r.recorded_steps)
        << row.evidence_path << ": every action from a skill again";
    // From the state recorded at a command's start (with the keyframes the commands before it left in the
    // host): the same again. One command per episode, rotating through them, keeps the cost linear in steps.
    if (r.commands > 1) {
      const std::uint32_t c = 1 + static_cast<std::uint32_t>(&row - rows.data()) % (r.commands - 1);
      const auto k = inproc::replay(row.evidence_path, {paths::config_dir(), {}, c, false, {}});
      EXPECT_TRUE(k.identical) << row.evidence_path << " from command " << c << ": "
                               << (k.first_divergence ? std::to_string(k.first_divergence->step) + " " +
                                                            k.first_divergence->body + " " + k.first_divergence->quantity
                                                      : "verdicts");
      resumed += k.identical;
      resumed_mid += k.identical && k.from_step > 0;
    }
    // The probe: a command closed-loop on the bus, from its recorded start, under the recorded θ. Every
    // command that failed, and one other per episode, rotating through them.
    const inproc::Recording recording = inproc::read_recording(row.evidence_path);
    for (std::uint32_t c = 0; row.arm != "full-perception" && c < r.commands; ++c) {
      const auto& end = recording.commands[c].end;
      if (c != static_cast<std::uint32_t>(&row - rows.data()) % r.commands && !(end && end->state == "failed")) continue;
      const auto p = evo::probe(row.evidence_path, {paths::config_dir(), {}, c, std::nullopt, false, {}});
      EXPECT_TRUE(p.reproduces) << row.evidence_path << " probe of command " << c << " (" << p.capability
                                << "): ended " << p.state << " at " << p.end_step << ", recorded "
                                << (p.recorded ? p.recorded->state + " at " + std::to_string(p.recorded->step) : "none")
                                << (p.first_divergence ? ", diverged at " + std::to_string(p.first_divergence->step) : "");
      ++probed;
      probes_reproduce += p.reproduces;
      failures_reproduce += p.reproduces && p.recorded && p.recorded->state == "failed";
      // And the rest of the episode from there: the governor restored from its snapshot at the dispatch
      // decides again, on the bus, every step and the episode's end as recorded over DDS.
      evo::ProbeOptions o{paths::config_dir(), {}, c, std::nullopt, false, {}};
      o.rest = true;
      const auto rest = evo::probe(row.evidence_path, o);
      EXPECT_TRUE(rest.reproduces) << row.evidence_path << " rest of the episode from command " << c << ": "
                                   << evo::to_json(rest).dump().substr(0, 600);
      rests_reproduce += rest.reproduces;
    }
    arms.insert(row.arm);
    cells.insert(row.cell);
  }
  EXPECT_EQ(identical, rows.size());
  EXPECT_GE(resumed_mid, 20u) << "restored mid-episode states replay identically";
  EXPECT_EQ(probes_reproduce, probed);
  EXPECT_EQ(rests_reproduce, probed);
  EXPECT_GE(probed, 45u);
  std::printf("%zu commands probed under the recorded θ, %zu reproduced (%zu of them recorded failures); the rest "
              "of the episode from each reproduced in %zu\n",
              probed, probes_reproduce, failures_reproduce, rests_reproduce);
  EXPECT_EQ(arms.size(), 5u);
  EXPECT_EQ(cells.size(), 6u);
  std::printf("%zu episodes over DDS replayed, %zu identical, %zu skill actions compared; %zu replays from a "
              "command's recorded state (%zu of them mid-episode) identical\n",
              rows.size(), identical, compared, resumed, resumed_mid);

  // The command line: one JSON object; a θ changed in a library copy refuses with exit 4 and names it.
  const std::string evidence = rows.front().evidence_path;
  auto [json_out, json_status] = itest::run_command(dh + " replay " + evidence + " --json");
  EXPECT_EQ(json_status, 0) << json_out;
  const auto j = nlohmann::json::parse(json_out);
  EXPECT_TRUE(j["identical"].get<bool>());
  EXPECT_TRUE(j["first_divergence"].is_null());
  EXPECT_EQ(j["steps"].get<unsigned>(), rows.front().steps);

  // A probe repeated side by side: every run ends alike, physics included, and reproduces the recording.
  const auto& full = *std::find_if(rows.begin(), rows.end(), [](const auto& r) { return r.arm == "full"; });
  auto [repeat_out, repeat_status] = itest::run_command(dh + " probe --evidence " + full.evidence_path +
                                                        " --command 0 --rest --repeats 3 --json");
  const auto repeats = nlohmann::json::parse(repeat_out);
  EXPECT_EQ(repeat_status, full.success ? 0 : 3) << repeat_out;
  EXPECT_TRUE(repeats["reproduces"].get<bool>()) << repeat_out;
  EXPECT_EQ(repeats["repeats"]["runs"].get<unsigned>(), 3u);
  EXPECT_EQ(repeats["repeats"]["passed"].get<unsigned>(), full.success ? 3u : 0u);
  EXPECT_TRUE(repeats["repeats"]["alike"].get<bool>()) << repeat_out;

  const auto library = env.runs / "library";
  std::filesystem::copy(paths::config_dir() / "library", library);
  for (const auto& file : std::filesystem::directory_iterator(library)) {
    std::ifstream in(file.path());
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    // Every descriptor's first θ value is raised by 1 %: any episode's grounded capability now differs.
    const auto at = text.find("\nparameters:\n");
    if (at == std::string::npos) continue;
    const auto line = at + 13, colon = text.find(':', line), end = text.find_first_of("#\n", colon);
    const double v = std::stod(text.substr(colon + 1, end - colon - 1));
    text.replace(colon + 1, end - colon - 1, " " + std::to_string(v * 1.01 + 0.001) + " ");
    std::ofstream(file.path()) << text;
  }
  auto [refused, refused_status] = itest::run_command(dh + " replay " + evidence + " --library " + library.string() + " 2>&1");
  EXPECT_EQ(refused_status, 4) << refused;
  EXPECT_NE(refused.find(" θ "), std::string::npos) << refused;
  EXPECT_NE(refused.find("is recorded; " + library.string()), std::string::npos) << refused;
  auto [drift, drift_status] =
      itest::run_command(dh + " replay " + evidence + " --library " + library.string() + " --allow-drift 2>&1");
  EXPECT_EQ(drift_status, 0) << drift;
  EXPECT_NE(drift.find("drift (allowed)"), std::string::npos) << drift;
}
