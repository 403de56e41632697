// Starts a set of services from a deploy/ YAML file (like a ROS 2 launch file) and stops them.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace dh::cli {

struct ServiceSpec {
  std::string name;
  std::string exec;               ///< executable name in the bin folder
  std::vector<std::string> args;
};

/// Reads `services:` from a launch file; throws ConfigError naming file and key.
std::vector<ServiceSpec> load_launch_file(const std::filesystem::path& file);

class Deployment {
 public:
  /// Starts every service from `bin_dir`, logs to `log_dir/<name>.log`; throws std::runtime_error
  /// naming the service that could not start (the ones already started are stopped).
  Deployment(const std::vector<ServiceSpec>& services, const std::filesystem::path& bin_dir,
             const std::filesystem::path& log_dir);
  ~Deployment();  ///< stop()
  Deployment(const Deployment&) = delete;
  Deployment& operator=(const Deployment&) = delete;

  /// SIGTERM, then SIGKILL after `grace_ms` for any that did not exit.
  void stop(int grace_ms = 3000);
  /// Sends `sig` to the named service (tests use SIGKILL to inject a crash); false if unknown.
  bool signal(const std::string& name, int sig);
  /// Names of services that exited on their own (crashed) since start.
  std::vector<std::string> exited();
  const std::filesystem::path& log_dir() const { return log_dir_; }

 private:
  struct Child {
    std::string name;
    pid_t pid;
    bool reaped = false;
  };
  std::vector<Child> children_;
  std::filesystem::path log_dir_;
};

}  // namespace dh::cli
