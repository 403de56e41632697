// System-test hosts: network namespaces made by deploy/testhosts (one per host of a multi-host launch
// file, joined by veth pairs to a bridge), each running its share of the launch file through `dh launch
// --host`. Everything is torn down afterwards, and the test checks nothing is left.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <memory>
#include <sstream>

#include "../integration/campaign_helpers.hpp"
#include "../integration/harness.hpp"
#include "dh/cli/launcher.hpp"

namespace dh::systest {

namespace fs = std::filesystem;

class TestHosts {
 public:
  TestHosts(const fs::path& launch_file, const fs::path& runs)
      : prefix_("dht" + std::to_string(getpid())), script_(paths::home() / "deploy" / "testhosts"),
        launch_file_(launch_file), runs_(runs), launch_(cli::load_launch(launch_file)) {
    std::string cmd = script_.string() + " up " + prefix_;
    for (const auto& h : launch_.hosts) cmd += " " + h.name + "=" + h.address;
    const auto [out, status] = itest::run_command(cmd + " 2>&1");
    up_ = status == 0;
    if (!up_) ADD_FAILURE() << cmd << " failed:\n" << out;
  }
  ~TestHosts() {
    deployment_.reset();
    const auto [out, status] = itest::run_command(script_.string() + " down " + prefix_ + " 2>&1");
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(namespaces_left(), "") << "deploy/testhosts down left namespaces behind";
  }
  TestHosts(const TestHosts&) = delete;
  TestHosts& operator=(const TestHosts&) = delete;

  bool up() const { return up_; }
  const cli::LaunchFile& launch() const { return launch_; }
  const std::string& prefix() const { return prefix_; }
  const fs::path& script() const { return script_; }

  /// Starts `dh launch FILE --host H` on every host (its runs folder is runs/H).
  void start() {
    std::vector<cli::ServiceSpec> hosts;
    for (const auto& h : launch_.hosts)
      hosts.push_back({"host_" + h.name, script_.string(),
                       {"run", prefix_, h.name, "env", "DH_RUNS_DIR=" + (runs_ / h.name).string(),
                        (paths::bin_dir() / "dh").string(), "launch", launch_file_.string(), "--host", h.name},
                       "", true});
    deployment_ = std::make_unique<cli::Deployment>(hosts, paths::bin_dir(), runs_ / "host_logs");
  }

  /// A shell command running `dh ARGS` on `host` with that host's DDS profile.
  std::string dh_on(const std::string& host, const std::string& args) const {
    const fs::path runs = runs_ / host;
    const std::string dh = (paths::bin_dir() / "dh").string();
    const auto [profile, status] =
        itest::run_command("DH_RUNS_DIR=" + runs.string() + " " + dh + " dds-profile " + launch_file_.string() + " --host " + host);
    EXPECT_EQ(status, 0) << profile;
    return script_.string() + " run " + prefix_ + " " + host + " env DH_RUNS_DIR=" + runs.string() +
           " DH_DDS_PROFILE=" + profile.substr(0, profile.find('\n')) + " " + dh + " " + args;
  }

  /// Namespaces of this test still present ("" when none).
  std::string namespaces_left() const {
    return itest::run_command("ip netns list | awk '{print $1}' | grep '^" + prefix_ + "-' || true").first;
  }

 private:
  std::string prefix_;
  fs::path script_, launch_file_, runs_;
  cli::LaunchFile launch_;
  bool up_ = false;
  std::unique_ptr<cli::Deployment> deployment_;
};

/// Counts DDS discovery multicast frames crossing the test hosts' bridge while it lives.
class MulticastCounter {
 public:
  MulticastCounter(const TestHosts& hosts, const fs::path& out) : out_(out) {
    pid_ = itest::spawn_shell("exec " + hosts.script().string() + " run " + hosts.prefix() + " switch python3 " +
                              (paths::home() / "tests" / "system" / "count_dds_multicast.py").string() + " br0 > " +
                              out.string() + " 2>&1");
    // Wait until it listens, so nothing sent at start is missed.
    for (int i = 0; i < 100 && read().find("listening") == std::string::npos; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ~MulticastCounter() { stop(); }
  /// Stops counting; the number of frames seen, or -1 when the counter failed (its output is in the file).
  long stop() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
    std::istringstream in(read());
    std::string first, count;
    in >> first >> count;
    return first == "listening" && !count.empty() ? std::stol(count) : -1;
  }
  std::string read() const {
    std::ifstream in(out_);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

 private:
  fs::path out_;
  pid_t pid_ = -1;
};

}  // namespace dh::systest
