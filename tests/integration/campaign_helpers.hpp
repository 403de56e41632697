// Helpers for integration tests that run `dh campaign` as a separate process and watch its database.
#pragma once

#include <spawn.h>

#include <filesystem>
#include <string>

#include "dh/campaign/db.hpp"
#include "harness.hpp"

extern char** environ;

namespace dh::itest {

/// Starts `/bin/sh -c cmd` without waiting; returns its pid (-1 when it could not start).
inline pid_t spawn_shell(const std::string& cmd) {
  pid_t pid = 0;
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return -1;
  return pid;
}

/// Rows recorded so far in a campaign database (0 before the campaign created it).
inline std::size_t rows_in(const std::filesystem::path& db) {
  try {
    return campaign::CampaignDb::read_rows(db).size();
  } catch (const campaign::CampaignError&) {
    return 0;
  }
}

/// Runs `dh campaign <plan>` into `env`'s c.db on deploy/campaign_local.yaml, started for it and stopped
/// after, and returns the rows; none, with a test failure that carries the campaign's output, when it fails.
inline std::vector<EpisodeRecord> local_campaign(const IsolatedEnv& env, const std::string& plan) {
  const auto db = env.runs / "c.db";
  cli::Deployment deployment(cli::load_launch_file(paths::home() / "deploy" / "campaign_local.yaml"), paths::bin_dir(),
                             env.runs / "logs");
  const auto [out, status] = run_command((paths::bin_dir() / "dh").string() + " campaign " + plan +
                                         " --ready-timeout-ms 20000 --db " + db.string() + " 2>&1");
  if (status != 0) {
    ADD_FAILURE() << "dh campaign " << plan << " exited " << status << ":\n" << out;
    return {};
  }
  return campaign::CampaignDb::read_rows(db);
}

}  // namespace dh::itest
