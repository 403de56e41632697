// Starts fake_openai_server.py (a scripted OpenAI-compatible server on 127.0.0.1, a free port) for one
// test and stops it; reads back the requests it recorded.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "../../support/python_server.hpp"

#ifndef DH_FAKE_OPENAI_SERVER
#error "DH_FAKE_OPENAI_SERVER must name fake_openai_server.py"
#endif

namespace dh::otest {

class FakeOpenAiServer {
 public:
  /// `mode`: see fake_openai_server.py; `sleep_s`: how long mode "sleep" waits before answering.
  explicit FakeOpenAiServer(const std::string& mode, double sleep_s = 30)
      : record_(record_path(mode)),
        server_(DH_FAKE_OPENAI_SERVER, {"--mode", mode, "--record", record_.string(), "--sleep-s", std::to_string(sleep_s)}) {}
  ~FakeOpenAiServer() {
    if (!::testing::Test::HasFailure()) std::filesystem::remove(record_);
  }
  FakeOpenAiServer(const FakeOpenAiServer&) = delete;
  FakeOpenAiServer& operator=(const FakeOpenAiServer&) = delete;

  int port() const { return server_.port(); }
  std::string endpoint() const { return "http://127.0.0.1:" + std::to_string(port()); }

  /// Every request so far: {"path", "authorization", "body"}.
  std::vector<nlohmann::json> requests() const {
    std::vector<nlohmann::json> out;
    std::ifstream in(record_);
    std::string line;
    while (std::getline(in, line)) out.push_back(nlohmann::json::parse(line));
    return out;
  }

 private:
  static std::filesystem::path record_path(const std::string& mode) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    auto p = std::filesystem::temp_directory_path() /
             ("dh_fake_openai_" + std::to_string(getpid()) + "_" + info->name() + "_" + mode + ".jsonl");
    std::filesystem::remove(p);
    return p;
  }
  std::filesystem::path record_;
  testsupport::PythonServer server_;
};

using testsupport::unused_port;

}  // namespace dh::otest
