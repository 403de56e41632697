// What the step log and the state log share: little-endian fields appended to a string, read back with a
// cursor that stops at a torn end, and files created and read with their magic checked. Internal to dh_sim.
#pragma once

#include <cstdio>
#include <cstring>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>

namespace dh::sim::binlog {

// x86-64 and aarch64 are little-endian; the formats say so for any other reader.
template <typename T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

/// A string with its u16 length; throws std::length_error for one longer than a u16 can say.
inline void put_string(std::string& out, const std::string& s) {
  if (s.size() > 0xffff) throw std::length_error("a log record's string of " + std::to_string(s.size()) + " bytes");
  put(out, static_cast<std::uint16_t>(s.size()));
  out += s;
}

struct Cursor {
  const std::string& bytes;
  std::size_t at = 0;
  template <typename T>
  bool get(T& v) {
    if (at + sizeof(T) > bytes.size()) return false;
    std::memcpy(&v, bytes.data() + at, sizeof(T));
    at += sizeof(T);
    return true;
  }
};

/// Creates `path` (and its folder), replacing an earlier file, and writes `header`; throws
/// std::runtime_error naming `what` and the file.
std::FILE* create(const std::filesystem::path& path, const char* what, const std::string& header);
/// Appends `record` whole and flushes it: a crash loses at most the record being written.
void append(std::FILE* file, const std::string& record);
/// The file's bytes after its 8-byte magic was checked; throws std::runtime_error naming the file when it
/// is missing (`missing_hint` says where it comes from) or is not a `what`.
std::string read(const std::filesystem::path& path, const char* what, const char (&magic)[8],
                 const char* missing_hint);
/// As read(), for a format with versions: `magics` are their 8-byte magics; returns the index of the one the
/// file has beside its bytes.
std::pair<std::string, std::size_t> read_versions(const std::filesystem::path& path, const char* what,
                                                  std::initializer_list<const char*> magics, const char* missing_hint);

}  // namespace dh::sim::binlog
