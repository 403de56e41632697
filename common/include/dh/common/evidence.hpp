// Append-only evidence store: one JSON object per line, flushed per record, so a crash loses at most
// the record being written. Records carry step, decision index, component, kind and reason.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace dh {

class EvidenceWriter {
 public:
  /// Opens (creating folders) `path` for appending; throws std::runtime_error naming the path.
  explicit EvidenceWriter(std::filesystem::path path);
  ~EvidenceWriter();
  EvidenceWriter(const EvidenceWriter&) = delete;
  EvidenceWriter& operator=(const EvidenceWriter&) = delete;

  /// Appends one record: adds "t_wall_ns", "seq" and the given fields, then flushes, then shows it to the
  /// tap, if one is set.
  void append(const std::string& component, const std::string& kind, nlohmann::json fields);
  /// Sees every record appended from now on (its kind and whole record), on the appending thread.
  void set_tap(std::function<void(const std::string& kind, const nlohmann::json& record)> tap) { tap_ = std::move(tap); }
  const std::filesystem::path& path() const { return path_; }
  std::size_t records() const { return seq_; }

 private:
  void write(const std::string& component, const std::string& kind, nlohmann::json& fields);
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::size_t seq_ = 0;
  std::mutex mutex_;
  std::function<void(const std::string&, const nlohmann::json&)> tap_;
};

/// Reads every complete record of an evidence file (a torn last line is skipped).
std::vector<nlohmann::json> read_evidence(const std::filesystem::path& path);

}  // namespace dh
