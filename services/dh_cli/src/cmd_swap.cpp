// dh swap CAPABILITY: start a new instance of a capability process while episodes run, wait until it
// announces itself, then stop the old instances on this host with SIGTERM, which makes them drain
// (refuse new commands, finish running ones). The governor routes new commands to the newest live
// instance, so no command is lost and the evidence names the instance that ran each one.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "commands.hpp"
#include "dh/common/config.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"

extern char** environ;

namespace dh::cli {

namespace {

using Clock = std::chrono::steady_clock;

/// "pick_place@host:1234" → {"host", 1234}; {"", 0} when the instance name does not say.
std::pair<std::string, pid_t> host_and_pid(const std::string& instance) {
  const auto at = instance.rfind('@'), colon = instance.rfind(':');
  if (at == std::string::npos || colon == std::string::npos || colon < at) return {"", 0};
  try {
    return {instance.substr(at + 1, colon - at - 1), static_cast<pid_t>(std::stol(instance.substr(colon + 1)))};
  } catch (const std::exception&) {
    return {"", 0};
  }
}

/// Whether `pid` runs the executable named `exec` (a pid named in an instance string may be stale or,
/// in another PID namespace, someone else's).
bool runs(pid_t pid, const std::string& exec) {
  std::error_code ec;
  const auto target = std::filesystem::read_symlink("/proc/" + std::to_string(pid) + "/exe", ec);
  return !ec && target.filename() == exec;
}

/// Gone or a zombie waiting for its parent (the launcher) to reap it.
bool exited(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_field, name, state;
  if (!(stat >> pid_field >> name >> state)) return true;
  return state == "Z" || state == "X";
}

pid_t spawn_detached(const std::filesystem::path& exe, const std::vector<std::string>& args,
                     const std::filesystem::path& log) {
  std::filesystem::create_directories(log.parent_path());
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  // It outlives this command: it must not keep this command's DDS sockets and shared-memory files open.
  posix_spawn_file_actions_addclosefrom_np(&fa, 3);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // Its own session: the new instance outlives this command and the terminal it was typed in.
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSID);
  std::vector<std::string> argv_s{exe.string()};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) throw std::runtime_error("cannot start " + exe.string() + ": " + std::strerror(rc));
  return pid;
}

}  // namespace

/// Stops the new instance politely (it may already hold commands), then for good; reaps it.
void stop_new(pid_t pid) {
  kill(pid, SIGTERM);
  for (int i = 0; i < 100 && waitpid(pid, nullptr, WNOHANG) == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  if (waitpid(pid, nullptr, WNOHANG) == 0) {
    kill(pid, SIGKILL);
    waitpid(pid, nullptr, 0);
  }
}

int cmd_swap(const SwapArgs& a) {
  install_shutdown_handlers();
  const std::string exec = a.exec.empty() ? "cap_" + a.capability : a.exec;
  const auto exe = paths::bin_dir() / exec;
  if (!std::filesystem::exists(exe))
    throw ConfigError("no executable " + exe.string() + " for capability '" + a.capability + "' (give --exec)");
  dds::Participant participant("dh_swap");
  std::mutex m;
  std::map<std::string, msg::CapabilityAnnounce> seen;  // instance → descriptor
  dds::Reader<msg::CapabilityAnnouncePubSubType> reader(participant, topics::kAnnounce, dds::Qos::Announce,
      {[&](const msg::CapabilityAnnounce& d, const auto&) {
         std::lock_guard l(m);
         if (d.capability() == a.capability) seen[d.instance()] = d;
       }, {}, {}});
  std::this_thread::sleep_for(std::chrono::milliseconds(a.discovery_ms));  // let the running instances answer
  std::map<std::string, msg::CapabilityAnnounce> old;
  {
    std::lock_guard l(m);
    old = seen;
  }

  std::vector<std::string> args;
  if (!a.library.empty()) args = {"--library", a.library};
  const auto log = paths::runs_dir() / "logs" / (exec + "-swap-" + std::to_string(getpid()) + ".log");
  const pid_t pid = spawn_detached(exe, args, log);
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  // The new instance is the one naming the process just started (instance "<capability>@<host>:<pid>").
  std::string fresh;
  const auto deadline = Clock::now() + std::chrono::seconds(a.wait_s);
  while (fresh.empty() && Clock::now() < deadline && !shutdown_requested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::lock_guard l(m);
    for (const auto& [instance, _] : seen)
      if (host_and_pid(instance) == std::pair<std::string, pid_t>{host, pid}) fresh = instance;
    if (fresh.empty() && exited(pid)) break;
  }
  if (fresh.empty()) {
    stop_new(pid);
    std::cerr << "error: the new instance of '" << a.capability << "' (" << exe.string() << ", pid " << pid << ") "
              << (shutdown_requested() ? "was interrupted before it announced itself"
                                       : "did not announce itself within " + std::to_string(a.wait_s) + " s")
              << "; it was stopped and the old instances keep running; see " << log.string() << "\n";
    return 1;
  }
  // Give the governor time to see the new instance before the old ones stop taking commands (a command
  // sent to a draining instance is refused and planned again).
  std::this_thread::sleep_for(std::chrono::seconds(2));

  // Every old instance on this host drains at once; then wait for all of them.
  nlohmann::json stopped = nlohmann::json::array(), elsewhere = nlohmann::json::array();
  std::vector<std::pair<std::string, pid_t>> draining;
  for (const auto& [instance, _] : old) {
    const auto [h, old_pid] = host_and_pid(instance);
    if (h != host || old_pid <= 0 || !runs(old_pid, exec) || kill(old_pid, SIGTERM) != 0) {
      elsewhere.push_back(instance);
      continue;
    }
    draining.emplace_back(instance, old_pid);
  }
  const auto drain_deadline = Clock::now() + std::chrono::seconds(a.drain_wait_s);
  for (const auto& [instance, old_pid] : draining) {
    while (!exited(old_pid) && Clock::now() < drain_deadline) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    stopped.push_back({{"instance", instance}, {"pid", old_pid}, {"exited", exited(old_pid)}});
  }
  const nlohmann::json out{{"capability", a.capability}, {"new_instance", fresh}, {"new_pid", pid},
                           {"log", log.string()}, {"stopped", stopped}, {"not_stopped_elsewhere", elsewhere}};
  if (a.json) {
    std::cout << out.dump() << "\n";
  } else {
    std::cout << "new instance " << fresh << " (pid " << pid << ", log " << log.string() << ")\n";
    for (const auto& s : stopped)
      std::cout << "old instance " << s["instance"].get<std::string>() << (s["exited"].get<bool>() ? " drained and stopped\n" : " still draining\n");
    for (const auto& e : elsewhere)
      std::cout << "old instance " << e.get<std::string>()
                << " is not a local process of this capability (another host, or gone): stop it where it runs (SIGTERM drains it)\n";
  }
  return 0;
}

}  // namespace dh::cli
