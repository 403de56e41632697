#include "dh/cli/launcher.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <set>
#include <stdexcept>
#include <thread>

#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"

extern char** environ;

namespace dh::cli {

namespace {

bool is_ipv4(const std::string& a) {
  in_addr out{};
  return inet_pton(AF_INET, a.c_str(), &out) == 1;
}

}  // namespace

const HostSpec& LaunchFile::host(const std::string& name) const {
  std::string known;
  for (const auto& h : hosts) {
    if (h.name == name) return h;
    known += (known.empty() ? "" : ", ") + h.name;
  }
  throw ConfigError(file.string() + ": no host '" + name + "' (hosts: " + known + ")");
}

std::vector<ServiceSpec> LaunchFile::services_on(const std::string& name, const std::filesystem::path& profile_dir) const {
  const HostSpec& h = host(name);
  std::vector<ServiceSpec> out;
  if (discovery == Discovery::Server && server_host == h.name)
    out.push_back({"discovery_server", "fast-discovery-server",
                   {"-x", (profile_dir / (file.stem().string() + "-discovery_server.xml")).string()}, h.name, true});
  for (const auto& s : services)
    if (s.host == h.name) out.push_back(s);
  return out;
}

LaunchFile load_launch(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  LaunchFile out;
  out.file = file;
  if (root.has("hosts")) {
    std::set<std::string> names, addresses;
    for (const ConfigNode& h : root.items("hosts")) {
      HostSpec host{h.get<std::string>("name"), h.get<std::string>("address")};
      if (!is_ipv4(host.address)) h.fail("address", "'" + host.address + "' is not an IPv4 address");
      if (!names.insert(host.name).second) h.fail("name", "host '" + host.name + "' is named twice");
      if (!addresses.insert(host.address).second) h.fail("address", host.address + " is given to two hosts");
      out.hosts.push_back(std::move(host));
    }
    if (out.hosts.empty()) root.fail("hosts", "lists no host");
    const std::string discovery = root.get_or<std::string>("discovery", "multicast");
    if (discovery == "server") {
      out.discovery = Discovery::Server;
      const ConfigNode ds = root.child("discovery_server");
      out.server_host = ds.get<std::string>("host");
      if (!names.count(out.server_host)) ds.fail("host", "'" + out.server_host + "' is not one of the hosts");
      out.server_port = ds.get_or<unsigned>("port", 11811);
      if (out.server_port == 0 || out.server_port > 65535) ds.fail("port", "not a UDP port (1-65535)");
    } else if (discovery != "multicast") {
      root.fail("discovery", "'" + discovery + "' is not multicast or server");
    }
  }
  for (const ConfigNode& s : root.items("services")) {
    ServiceSpec spec{s.get<std::string>("name"), s.get<std::string>("exec"),
                     s.get_or<std::vector<std::string>>("args", {}), s.get_or<std::string>("host", "")};
    if (spec.exec.find('/') != std::string::npos)
      s.fail("exec", "give the executable's name; it is looked up in the build's bin folder");
    if (out.multi_host() && spec.host.empty()) s.fail("host", "missing: a multi-host file says which host runs each service");
    if (out.multi_host() && !std::any_of(out.hosts.begin(), out.hosts.end(),
                                         [&](const HostSpec& h) { return h.name == spec.host; }))
      s.fail("host", "'" + spec.host + "' is not one of the hosts");
    if (!out.multi_host() && !spec.host.empty()) s.fail("host", "this file has no hosts: section");
    out.services.push_back(std::move(spec));
  }
  if (out.services.empty()) root.fail("services", "lists no service");
  if (root.has("security")) {
    // Each service runs with its own secured profile (its identity and permissions), made by
    // deploy/security/make_keys into this folder.
    std::filesystem::path dir = root.get<std::string>("security");
    if (dir.is_relative()) dir = paths::runs_dir() / dir;
    for (auto& s : out.services) {
      const auto profile = dir / (s.name + ".xml");
      if (!std::filesystem::exists(profile))
        root.fail("security", "no secured profile " + profile.string() + " for service '" + s.name +
                                  "'; make the keys first: deploy/security/make_keys " + dir.string());
      s.env["DH_DDS_PROFILE"] = profile.string();
    }
  }
  return out;
}

std::vector<ServiceSpec> load_launch_file(const std::filesystem::path& file) {
  LaunchFile launch = load_launch(file);
  if (launch.multi_host())
    throw ConfigError(file.string() + " is a multi-host launch file: run `dh launch " + file.string() +
                      " --host NAME` on each host");
  return launch.services;
}

namespace {

/// Starts one service, its output appended to `log`; returns its pid or throws naming it.
pid_t spawn(const ServiceSpec& s, const std::filesystem::path& bin_dir, const std::filesystem::path& log) {
  const auto exe = s.from_path ? std::filesystem::path(s.exec) : bin_dir / s.exec;
  if (!s.from_path && !std::filesystem::exists(exe))
    throw std::runtime_error("service '" + s.name + "': executable " + exe.string() + " not found (build first)");
  std::vector<std::string> argv_s{exe.string()};
  argv_s.insert(argv_s.end(), s.args.begin(), s.args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  // This process's environment, with the service's own variables in place of any of the same name.
  std::vector<std::string> env_s;
  for (char** e = environ; *e; ++e) {
    const std::string var(*e);
    if (!s.env.count(var.substr(0, var.find('=')))) env_s.push_back(var);
  }
  for (const auto& [k, v] : s.env) env_s.push_back(k + "=" + v);
  std::vector<char*> envp;
  for (auto& e : env_s) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int rc = s.from_path ? posix_spawnp(&pid, exe.c_str(), &fa, nullptr, argv.data(), envp.data())
                             : posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0)
    throw std::runtime_error("service '" + s.name + "': cannot start " + exe.string() + ": " + std::strerror(rc));
  return pid;
}

}  // namespace

Deployment::Deployment(const std::vector<ServiceSpec>& services, const std::filesystem::path& bin_dir,
                       const std::filesystem::path& log_dir)
    : bin_dir_(bin_dir), log_dir_(log_dir) {
  std::filesystem::create_directories(log_dir);
  for (const auto& s : services) {
    try {
      children_.push_back({s, spawn(s, bin_dir_, log_dir_ / (s.name + ".log"))});
    } catch (...) {
      stop(0);
      throw;
    }
  }
}

bool Deployment::restart(const std::string& name) {
  for (auto& c : children_)
    if (c.spec.name == name && c.reaped) {
      c.pid = spawn(c.spec, bin_dir_, log_dir_ / (c.spec.name + ".log"));
      c.reaped = false;
      return true;
    }
  return false;
}

std::vector<std::pair<std::string, pid_t>> Deployment::running() const {
  std::vector<std::pair<std::string, pid_t>> out;
  for (const auto& c : children_)
    if (!c.reaped) out.emplace_back(c.spec.name, c.pid);
  return out;
}

Deployment::~Deployment() { stop(); }

bool Deployment::signal(const std::string& name, int sig) {
  for (auto& c : children_)
    if (c.spec.name == name && !c.reaped) return kill(c.pid, sig) == 0;
  return false;
}

std::vector<std::string> Deployment::exited() {
  std::vector<std::string> out;
  for (auto& c : children_) {
    if (c.reaped) continue;
    int status = 0;
    if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
      c.reaped = true;
      out.push_back(c.spec.name);
    }
  }
  return out;
}

void Deployment::stop(int grace_ms) {
  for (auto& c : children_)
    if (!c.reaped) kill(c.pid, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(grace_ms);
  for (auto& c : children_) {
    while (!c.reaped) {
      int status = 0;
      if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
        c.reaped = true;
        break;
      }
      if (std::chrono::steady_clock::now() >= deadline) {
        kill(c.pid, SIGKILL);
        waitpid(c.pid, &status, 0);
        c.reaped = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
}

}  // namespace dh::cli
