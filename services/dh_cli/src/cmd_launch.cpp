// dh launch / dh dds-profile: run a deployment's services on this host.
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <map>
#include <thread>

#include "commands.hpp"
#include "dh/cli/dds_profile.hpp"
#include "dh/cli/launcher.hpp"
#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"

namespace dh::cli {

namespace {

/// --restart starts an exited service again only if it had run at least this long.
constexpr std::chrono::seconds kMinUptimeForRestart{5};

std::filesystem::path launch_path(const std::string& file) {
  return file.empty() ? paths::home() / "deploy" / "local.yaml" : std::filesystem::path(file);
}

/// The services this host runs; for a multi-host file also points DH_DDS_PROFILE (inherited by the
/// services) at the host's own profile.
std::vector<ServiceSpec> this_hosts_share(const LaunchFile& launch, const std::string& host) {
  if (!launch.multi_host()) {
    if (!host.empty())
      throw ConfigError(launch.file.string() + " has no hosts: section; run it without --host");
    return launch.services;
  }
  if (host.empty()) {
    std::string names;
    for (const auto& h : launch.hosts) names += " " + h.name;
    throw ConfigError(launch.file.string() + " is a multi-host launch file: give --host, one of:" + names);
  }
  const auto dir = paths::runs_dir() / "dds";
  const auto profile = write_host_profile(launch, host, dir);
  if (launch.discovery == Discovery::Server && launch.server_host == host) write_server_profile(launch, dir);
  setenv("DH_DDS_PROFILE", profile.c_str(), 1);
  std::cerr << "host " << host << " (" << launch.host(host).address << "): DDS profile " << profile.string()
            << " (export DH_DDS_PROFILE=" << profile.string() << " for dh commands on this host)\n";
  return launch.services_on(host, dir);
}

/// `name`, found on PATH, as an absolute path ("" when it is not there).
std::string on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  for (std::size_t start = 0; start <= dirs.size();) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    const auto candidate = std::filesystem::path(dirs.substr(start, end - start)) / name;
    if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  return "";
}

}  // namespace

int cmd_launch(const std::string& file, const std::string& host, bool restart, bool list) {
  using Clock = std::chrono::steady_clock;
  install_shutdown_handlers();
  const auto path = launch_path(file);
  const LaunchFile launch = load_launch(path);
  const auto services = this_hosts_share(launch, host);
  if (list) {  // name, executable, arguments: what install_units turns into systemd units
    for (const auto& s : services) {
      std::string args;
      for (const auto& a : s.args) args += (args.empty() ? "" : " ") + a;
      const std::string exe = s.from_path ? on_path(s.exec) : (paths::bin_dir() / s.exec).string();
      if (exe.empty()) throw ConfigError("service '" + s.name + "': " + s.exec + " is not on PATH (install fastdds-tools)");
      std::cout << s.name << "\t" << exe << "\t" << args << "\n";
    }
    return 0;
  }
  Deployment d(services, paths::bin_dir(), paths::runs_dir() / "logs");
  std::map<std::string, Clock::time_point> started;
  for (const auto& s : services) started[s.name] = Clock::now();
  std::cerr << "deployment " << path.string() << " running (logs in " << d.log_dir().string() << "); Ctrl-C stops it\n";
  while (!shutdown_requested()) {
    for (const auto& name : d.exited()) {
      const auto log = (d.log_dir() / (name + ".log")).string();
      // One that ends right after its start (a missing file, a bad option) would only end again.
      if (restart && Clock::now() - started[name] >= kMinUptimeForRestart) {
        std::cerr << "service '" << name << "' exited (" << log << "); starting it again\n";
        d.restart(name);
        started[name] = Clock::now();
      } else {
        std::cerr << "service '" << name << "' exited; why: " << log << "\n";
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return 0;
}

int cmd_dds_profile(const std::string& file, const std::string& host) {
  const LaunchFile launch = load_launch(launch_path(file));
  if (!launch.multi_host()) throw ConfigError(launch.file.string() + " has no hosts: section (it uses DH_DDS_PROFILE as is)");
  std::cout << write_host_profile(launch, launch.host(host).name, paths::runs_dir() / "dds").string() << "\n";
  return 0;
}

}  // namespace dh::cli
