// The cell's dry run as a user starts it (deploy/cell/dry_run), cut to one trial of its first task: every
// process of the cell comes up against the RTDE test controller, the episode ends on the verdict
// perception gives, and the table sets the oracle's verdict beside it.
#include <fstream>
#include <sstream>

#include "harness.hpp"

namespace dh {
namespace {

TEST(CellDryRun, OneTrialOfTheRingOverThePostIsTabledWithBothVerdicts) {
  itest::IsolatedEnv env;
  const auto out = env.runs / "dry-run";
  const auto script = paths::home() / "deploy" / "cell" / "dry_run";
  auto [log, status] =
      itest::run_command(script.string() + " --trials 1 --tasks 0 --first-seed 3 --out " + out.string() + " 2>&1");
  ASSERT_EQ(status, 0) << log;
  std::ifstream trials(out / "trials.tsv");
  std::string header, row;
  ASSERT_TRUE(std::getline(trials, header) && std::getline(trials, row)) << log;
  EXPECT_EQ(header, "task\tseed\tperceived\toracle\toutcome\tsteps\twhy");
  std::istringstream fields(row);
  std::string task, seed, perceived, oracle, outcome;
  std::getline(fields, task, '\t');
  std::getline(fields, seed, '\t');
  std::getline(fields, perceived, '\t');
  std::getline(fields, oracle, '\t');
  std::getline(fields, outcome, '\t');
  EXPECT_EQ(task, "0");
  EXPECT_EQ(seed, "3");
  EXPECT_EQ(perceived, "1") << row;
  EXPECT_EQ(oracle, "1") << "the test controller's world disagrees: " << row;
  EXPECT_EQ(outcome, "success") << row;
  std::ifstream table(out / "table.md");
  std::stringstream t;
  t << table.rdbuf();
  EXPECT_NE(t.str().find("| 0 (put the ring over the post) | 1 | 1/1 | 1/1 | 0 |"), std::string::npos) << t.str();
}

}  // namespace
}  // namespace dh
