#include "dh/cli/launcher.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <stdexcept>
#include <thread>

#include "dh/common/config.hpp"

extern char** environ;

namespace dh::cli {

std::vector<ServiceSpec> load_launch_file(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  std::vector<ServiceSpec> out;
  for (const ConfigNode& s : root.items("services")) {
    ServiceSpec spec{s.get<std::string>("name"), s.get<std::string>("exec"),
                     s.get_or<std::vector<std::string>>("args", {})};
    if (spec.exec.find('/') != std::string::npos)
      s.fail("exec", "give the executable's name; it is looked up in the build's bin folder");
    out.push_back(std::move(spec));
  }
  if (out.empty()) root.fail("services", "lists no service");
  return out;
}

Deployment::Deployment(const std::vector<ServiceSpec>& services, const std::filesystem::path& bin_dir,
                       const std::filesystem::path& log_dir)
    : log_dir_(log_dir) {
  std::filesystem::create_directories(log_dir);
  for (const auto& s : services) {
    const auto exe = bin_dir / s.exec;
    if (!std::filesystem::exists(exe)) {
      stop(0);
      throw std::runtime_error("service '" + s.name + "': executable " + exe.string() + " not found (build first)");
    }
    std::vector<std::string> argv_s{exe.string()};
    argv_s.insert(argv_s.end(), s.args.begin(), s.args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    const std::string log = (log_dir / (s.name + ".log")).string();
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
      stop(0);
      throw std::runtime_error("service '" + s.name + "': cannot start " + exe.string());
    }
    children_.push_back({s.name, pid});
  }
}

Deployment::~Deployment() { stop(); }

bool Deployment::signal(const std::string& name, int sig) {
  for (auto& c : children_)
    if (c.name == name && !c.reaped) return kill(c.pid, sig) == 0;
  return false;
}

std::vector<std::string> Deployment::exited() {
  std::vector<std::string> out;
  for (auto& c : children_) {
    if (c.reaped) continue;
    int status = 0;
    if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
      c.reaped = true;
      out.push_back(c.name);
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
