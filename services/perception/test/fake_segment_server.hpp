// fake_segment_server.py on 127.0.0.1 for a test suite; reads back the requests it recorded.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "python_server.hpp"  // tests/support

#ifndef DH_FAKE_SEGMENT_SERVER
#error "DH_FAKE_SEGMENT_SERVER must name fake_segment_server.py"
#endif

namespace dh::perception::testing {

class FakeSegmentServer {
 public:
  explicit FakeSegmentServer(double sleep_s)
      : record_(record_path()), server_(DH_FAKE_SEGMENT_SERVER, {"--record", record_.string(), "--sleep-s", std::to_string(sleep_s)}) {}
  ~FakeSegmentServer() { std::filesystem::remove(record_); }
  FakeSegmentServer(const FakeSegmentServer&) = delete;
  FakeSegmentServer& operator=(const FakeSegmentServer&) = delete;

  /// The endpoint answering in `mode` (see fake_segment_server.py).
  std::string url(const std::string& mode) const {
    return "http://127.0.0.1:" + std::to_string(server_.port()) + "/" + mode + "/segment";
  }

  /// Every request so far: {"path", "body"}.
  std::vector<nlohmann::json> requests() const {
    std::vector<nlohmann::json> out;
    std::ifstream in(record_);
    std::string line;
    while (std::getline(in, line)) out.push_back(nlohmann::json::parse(line));
    return out;
  }

 private:
  static std::filesystem::path record_path() {
    auto p = std::filesystem::temp_directory_path() / ("dh_fake_segment_" + std::to_string(getpid()) + ".jsonl");
    std::filesystem::remove(p);
    return p;
  }
  std::filesystem::path record_;
  testsupport::PythonServer server_;
};

using testsupport::unused_port;

}  // namespace dh::perception::testing
