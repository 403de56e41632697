// Starts a set of services from a deploy/ YAML file (like a ROS 2 launch file) and stops them.
//
// A launch file lists `services:`. A multi-host file also names its `hosts:` (name and address), gives
// every service a `host:` and says how DDS discovers peers (`discovery: multicast` on the hosts' links,
// or `discovery: server` with a Fast DDS discovery server on `discovery_server: {host, port}`); each host
// then runs its own share with a DDS profile made for it (dds_profile.hpp). `security: DIR` (relative to
// DH_RUNS_DIR) runs every service with its own DDS-Security profile DIR/<service name>.xml.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace dh::cli {

struct ServiceSpec {
  std::string name;
  std::string exec;               ///< executable name in the bin folder (or on PATH when from_path)
  std::vector<std::string> args;
  std::string host = {};          ///< multi-host files: the host that runs it
  bool from_path = false;         ///< a system program (the discovery server), looked up on PATH
  std::map<std::string, std::string> env = {};  ///< variables set for this service only
};

struct HostSpec {
  std::string name;
  std::string address;  ///< IPv4 address of the host on the deployment's network
};

enum class Discovery { Multicast, Server };

struct LaunchFile {
  std::filesystem::path file;
  std::vector<HostSpec> hosts;  ///< empty: a single-host file on the loopback profile
  Discovery discovery = Discovery::Multicast;
  std::string server_host;      ///< Discovery::Server: the host running fast-discovery-server
  unsigned server_port = 11811;
  std::vector<ServiceSpec> services;

  bool multi_host() const { return !hosts.empty(); }
  /// Throws ConfigError listing the hosts when `name` is not one of them.
  const HostSpec& host(const std::string& name) const;
  /// What `host` runs, with the discovery server first when it is that host's job (it reads its profile
  /// from `profile_dir`, see write_server_profile()).
  std::vector<ServiceSpec> services_on(const std::string& host, const std::filesystem::path& profile_dir) const;
};

/// Reads a launch file; throws ConfigError naming file and key (unknown host, duplicate address, ...).
LaunchFile load_launch(const std::filesystem::path& file);
/// The services of a single-host launch file; throws ConfigError for a multi-host one (it needs a host).
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
  /// Starts an exited service again (same arguments, same log); false if `name` is unknown or running.
  bool restart(const std::string& name);
  /// Services running now, with their pids.
  std::vector<std::pair<std::string, pid_t>> running() const;
  const std::filesystem::path& log_dir() const { return log_dir_; }

 private:
  struct Child {
    ServiceSpec spec;
    pid_t pid;
    bool reaped = false;
  };
  std::vector<Child> children_;
  std::filesystem::path bin_dir_, log_dir_;
};

}  // namespace dh::cli
