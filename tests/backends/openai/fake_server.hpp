// Starts fake_openai_server.py (a scripted OpenAI-compatible server on 127.0.0.1, a free port) for one
// test and stops it; reads back the requests it recorded.
#pragma once

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#ifndef DH_FAKE_OPENAI_SERVER
#error "DH_FAKE_OPENAI_SERVER must name fake_openai_server.py"
#endif

namespace dh::otest {

class FakeOpenAiServer {
 public:
  /// `mode`: see fake_openai_server.py; `sleep_s`: how long mode "sleep" waits before answering.
  explicit FakeOpenAiServer(const std::string& mode, double sleep_s = 30) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    record_ = std::filesystem::temp_directory_path() /
              ("dh_fake_openai_" + std::to_string(getpid()) + "_" + info->name() + "_" + mode + ".jsonl");
    std::filesystem::remove(record_);
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    const std::string sleep = std::to_string(sleep_s);
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlive the test
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execlp("python3", "python3", DH_FAKE_OPENAI_SERVER, "--mode", mode.c_str(), "--record", record_.c_str(),
             "--sleep-s", sleep.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    std::string line;
    pollfd p{fds[0], POLLIN, 0};
    while (line.find('\n') == std::string::npos && poll(&p, 1, 15000) > 0) {
      char buf[64];
      const ssize_t n = read(fds[0], buf, sizeof buf);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
    }
    close(fds[0]);
    port_ = std::atoi(line.c_str());
    if (port_ <= 0) {
      stop();
      throw std::runtime_error("fake_openai_server.py did not print its port (python3 missing?)");
    }
  }
  ~FakeOpenAiServer() {
    stop();
    if (!::testing::Test::HasFailure()) std::filesystem::remove(record_);
  }
  FakeOpenAiServer(const FakeOpenAiServer&) = delete;
  FakeOpenAiServer& operator=(const FakeOpenAiServer&) = delete;

  int port() const { return port_; }
  std::string endpoint() const { return "http://127.0.0.1:" + std::to_string(port_); }

  /// Every request so far: {"path", "authorization", "body"}.
  std::vector<nlohmann::json> requests() const {
    std::vector<nlohmann::json> out;
    std::ifstream in(record_);
    std::string line;
    while (std::getline(in, line)) out.push_back(nlohmann::json::parse(line));
    return out;
  }

 private:
  void stop() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
  }
  pid_t pid_ = -1;
  int port_ = 0;
  std::filesystem::path record_;
};

/// A loopback port nothing listens on (bound, read, closed).
inline int unused_port() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  close(s);
  return ntohs(a.sin_port);
}

}  // namespace dh::otest
