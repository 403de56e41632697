// Integration-test harness: real service processes on real DDS, isolated per test by a DDS domain of
// their own and a temporary runs folder. Every profile stays on loopback (deploy/dds/loopback.xml).
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <mutex>
#include <string>
#include <thread>

#include "dh/cli/launcher.hpp"
#include "dh/common/paths.hpp"

namespace dh::itest {

/// Takes a DDS domain no other running test holds (an flock per domain, released when the test's
/// process ends) and a fresh runs folder; both are inherited by the services the test starts.
struct IsolatedEnv {
  std::filesystem::path runs;
  int lock_fd = -1;
  IsolatedEnv() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    for (int domain = 100; domain < 200 && lock_fd < 0; ++domain) {
      const auto lock = std::filesystem::temp_directory_path() / ("dh_domain_" + std::to_string(domain) + ".lock");
      const int fd = open(lock.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
      if (fd >= 0 && flock(fd, LOCK_EX | LOCK_NB) == 0) {
        lock_fd = fd;
        setenv("DH_DOMAIN_ID", std::to_string(domain).c_str(), 1);
      } else if (fd >= 0) {
        close(fd);
      }
    }
    if (lock_fd < 0) ADD_FAILURE() << "no free DDS domain in 100..199";
    runs = std::filesystem::temp_directory_path() / ("dh_itest_" + std::to_string(getpid()) + "_" + info->name());
    std::filesystem::remove_all(runs);
    std::filesystem::create_directories(runs);
    setenv("DH_RUNS_DIR", runs.c_str(), 1);
  }
  ~IsolatedEnv() {
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(runs);
    if (lock_fd >= 0) close(lock_fd);
  }
};

/// A file's whole text ("" when it cannot be read): a service's log, say.
inline std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline cli::ServiceSpec service(const std::string& name, std::vector<std::string> args = {}) {
  return {name, name, std::move(args)};
}

/// Waits until `pred` holds or `timeout` passes; returns pred().
template <class Pred>
bool wait_until(std::mutex& m, std::condition_variable& cv, std::chrono::milliseconds timeout, Pred pred) {
  std::unique_lock l(m);
  return cv.wait_for(l, timeout, pred);
}

/// Runs a command, returns its stdout and exit status.
inline std::pair<std::string, int> run_command(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {"", -1};
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = pclose(p);
  return {out, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

}  // namespace dh::itest
