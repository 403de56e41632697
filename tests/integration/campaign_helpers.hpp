// Helpers for integration tests that run `dh campaign` as a separate process and watch its database.
#pragma once

#include <spawn.h>

#include <filesystem>
#include <string>

#include "dh/campaign/db.hpp"

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

}  // namespace dh::itest
