// One episode loop: the same episodes over DDS (every process of campaign_local.yaml) and in process (the
// lock-step bus) give the same outcome, the same steps and the same evidence records. Wall-clock fields
// (t_wall_ns, the decision latency, a snapshot's waits), the record order across topics (DDS does not order two topics), the
// channel, episode ids and instance names (host and pid) aside.
#include <nlohmann/json.hpp>

#include <map>
#include <regex>

#include "campaign_helpers.hpp"
#include "dh/common/evidence.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/stack.hpp"
#include "harness.hpp"

using namespace dh;

namespace {

/// The records of an evidence file as comparable text, sorted.
std::vector<std::string> normalised(const std::filesystem::path& file) {
  const auto records = read_evidence(file);
  std::string episode;
  for (const auto& r : records)
    if (r.value("kind", "") == "episode_start") episode = r.value("episode_id", "");
  static const std::regex instance(R"re("([a-z_]+)@[^"]*")re");
  std::vector<std::string> out;
  for (auto r : records) {
    for (const char* wall : {"t_wall_ns", "seq", "latency_ns", "channel", "waits"}) r.erase(wall);
    std::string text = r.dump();
    for (auto at = text.find(episode); !episode.empty() && at != std::string::npos; at = text.find(episode, at))
      text.replace(at, episode.size(), "EP");
    out.push_back(std::regex_replace(text, instance, "\"$1@X\""));
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// Where the first records of each side part: the text around the first character that differs.
std::string first_difference(const std::vector<std::string>& dds, const std::vector<std::string>& inproc) {
  if (dds.empty() || inproc.empty())
    return (dds.empty() ? "in process " + inproc.front() : "over DDS " + dds.front()).substr(0, 400);
  const std::string &a = dds.front(), &b = inproc.front();
  std::size_t at = 0;
  while (at < a.size() && at < b.size() && a[at] == b[at]) ++at;
  const std::size_t from = at > 120 ? at - 120 : 0;
  return "over DDS ..." + a.substr(from, 240) + "... in process ..." + b.substr(from, 240) + "...";
}

}  // namespace

TEST(Equivalence, EightyEpisodesOverDdsAndInProcessAreTheSame) {
  itest::IsolatedEnv env;
  const auto rows = itest::local_campaign(env, "--cells goal-task,goal-swap,long-task,long-swap --tasks 0-9 --seeds 21-22");
  ASSERT_EQ(rows.size(), 80u);

  inproc::Stack stack(paths::config_dir());
  const auto suites = load_suites(paths::config_dir());
  std::size_t same = 0, successes = 0;
  for (const auto& row : rows) {
    const std::string what = row.cell + " " + std::to_string(row.task) + " seed " + std::to_string(row.seed);
    const auto path = env.runs / "inproc" / (row.cell + "_" + std::to_string(row.task) + "_" + std::to_string(row.seed) + ".jsonl");
    const auto in = stack.run(find_task(suites, row.cell, row.task), row.seed, row.arm, path);
    EXPECT_EQ(in.success, row.success) << what;
    EXPECT_EQ(to_string(in.outcome), row.outcome) << what;
    EXPECT_EQ(in.steps, row.steps) << what;
    const auto dds_records = normalised(row.evidence_path), inproc_records = normalised(path);
    std::vector<std::string> only_dds, only_inproc;
    std::set_difference(dds_records.begin(), dds_records.end(), inproc_records.begin(), inproc_records.end(),
                        std::back_inserter(only_dds));
    std::set_difference(inproc_records.begin(), inproc_records.end(), dds_records.begin(), dds_records.end(),
                        std::back_inserter(only_inproc));
    EXPECT_TRUE(only_dds.empty() && only_inproc.empty())
        << what << ": " << only_dds.size() << " record(s) only over DDS, " << only_inproc.size()
        << " only in process; first: " << first_difference(only_dds, only_inproc);
    same += only_dds.empty() && only_inproc.empty() && in.success == row.success && in.steps == row.steps;
    successes += row.success;
  }
  EXPECT_EQ(same, rows.size());
  std::printf("%zu of %zu episodes the same over DDS and in process (%zu successes)\n", same, rows.size(), successes);
}
