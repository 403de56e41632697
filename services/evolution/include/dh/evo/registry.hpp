// The registry (issue 16): an append-only, dated record of every candidate library and the decision on it,
// one JSON object per line in <dir>/registry.jsonl. Each line carries the SHA-256 of the line before it
// and <dir>/registry.head the last line's, so a line edited or removed afterwards is found on the next
// read; appends hold a lock. An admitted candidate's library is frozen as a snapshot,
// <dir>/snapshots/<version>/ (named by its library version, the hash of its θ; files read-only), runnable
// with `dh campaign --library`; a rejected one changes nothing: the current library stays the last
// admitted.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dh::evo {

class Registry {
 public:
  explicit Registry(std::filesystem::path dir);

  /// Every entry in order. Throws std::runtime_error naming the file and line when a line is not JSON or
  /// the chain of hashes is broken (a line edited, inserted or removed).
  std::vector<nlohmann::json> entries() const;
  /// The entry with `id`; nullopt when none.
  std::optional<nlohmann::json> find(const std::string& id) const;
  /// Appends `entry` with its id ("r<seq>"), UTC time, decision and the previous line's hash; when
  /// `admitted`, freezes `library` (a library folder whose version is entry["candidate_version"]) as a
  /// snapshot first. Returns the entry as written.
  nlohmann::json append(nlohmann::json entry, const std::filesystem::path& library, bool admitted);
  /// The last admitted snapshot's folder; nullopt before the first admission.
  std::optional<std::filesystem::path> current() const;

  std::filesystem::path file() const { return dir_ / "registry.jsonl"; }
  std::filesystem::path head() const { return dir_ / "registry.head"; }
  std::filesystem::path snapshot(const std::string& version) const { return dir_ / "snapshots" / version; }

 private:
  struct Chain {
    std::vector<nlohmann::json> entries;
    std::string last;  ///< the last line's hash (the chain's start when there is none)
  };
  /// Every entry with the chain checked, head included; throws as entries() does.
  Chain read_chain() const;

  std::filesystem::path dir_;
};

}  // namespace dh::evo
