// fake_policy_server.py (openpi's protocol, by hand) in its own process on 127.0.0.1, for the tests that
// need a real policy server. DH_POLICY_TEST_PYTHON and DH_FAKE_POLICY_SERVER come from CMake.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace dh::test {

// fake_policy_server.py in its own process; stopped (stdin closed, SIGTERM) when this goes.
class FakeServer {
 public:
  explicit FakeServer(const std::vector<std::string>& args) {
    const std::string python = DH_POLICY_TEST_PYTHON;
    if (python.empty()) {
      ADD_FAILURE() << "no python3 with websockets, msgpack and numpy was found at configure time "
                       "(install python3-websockets python3-msgpack python3-numpy)";
      return;
    }
    int in[2], out[2];
    if (pipe2(in, O_CLOEXEC) != 0 || pipe2(out, O_CLOEXEC) != 0) {
      ADD_FAILURE() << "pipe: " << std::strerror(errno);
      return;
    }
    std::vector<std::string> argv_s{python, DH_FAKE_POLICY_SERVER};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, in[0], 0);
    posix_spawn_file_actions_adddup2(&actions, out[1], 1);
    const int rc = posix_spawn(&pid_, python.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(in[0]);
    ::close(out[1]);
    stdin_fd_ = in[1];
    stdout_fd_ = out[0];
    if (rc != 0) {
      pid_ = -1;
      ADD_FAILURE() << "cannot start " << python << ": " << std::strerror(rc);
      return;
    }
    // Its first line: "PORT <n>".
    std::string text;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (text.find('\n') == std::string::npos && std::chrono::steady_clock::now() < deadline) {
      pollfd p{stdout_fd_, POLLIN, 0};
      if (poll(&p, 1, 200) <= 0) continue;
      char buf[256];
      const auto n = ::read(stdout_fd_, buf, sizeof buf);
      if (n <= 0) break;
      text.append(buf, std::size_t(n));
    }
    if (text.rfind("PORT ", 0) == 0 && text.find('\n') != std::string::npos)
      port_ = std::atoi(text.c_str() + 5);
    if (port_ <= 0) ADD_FAILURE() << "the fake policy server did not print its port; it said: " << text;
  }
  ~FakeServer() {
    if (stdin_fd_ >= 0) ::close(stdin_fd_);
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      int status = 0;
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
      while (waitpid(pid_, &status, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > deadline) {
          kill(pid_, SIGKILL);
          waitpid(pid_, &status, 0);
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    if (stdout_fd_ >= 0) ::close(stdout_fd_);
  }
  FakeServer(const FakeServer&) = delete;
  FakeServer& operator=(const FakeServer&) = delete;

  std::string url() const { return "ws://127.0.0.1:" + std::to_string(port_); }
  bool running() const { return port_ > 0; }

 private:
  pid_t pid_ = -1;
  int stdin_fd_ = -1, stdout_fd_ = -1;
  int port_ = 0;
};

}  // namespace dh::test
