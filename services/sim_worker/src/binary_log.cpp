#include "binary_log.hpp"

#include <cerrno>
#include <fstream>
#include <stdexcept>

namespace dh::sim::binlog {

std::FILE* create(const std::filesystem::path& path, const char* what, const std::string& header) {
  std::filesystem::create_directories(path.parent_path());
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw std::runtime_error(std::string("cannot write the ") + what + " " + path.string() + ": " + std::strerror(errno));
  append(file, header);
  return file;
}

void append(std::FILE* file, const std::string& record) {
  std::fwrite(record.data(), 1, record.size(), file);
  std::fflush(file);
}

std::string read(const std::filesystem::path& path, const char* what, const char (&magic)[8],
                 const char* missing_hint) {
  return read_versions(path, what, {magic}, missing_hint).first;
}

std::pair<std::string, std::size_t> read_versions(const std::filesystem::path& path, const char* what,
                                                  std::initializer_list<const char*> magics, const char* missing_hint) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string("no ") + what + " " + path.string() + " (" + missing_hint + ")");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t i = 0;
  for (const char* magic : magics) {
    if (bytes.size() >= 8 && std::memcmp(bytes.data(), magic, 8) == 0) return {std::move(bytes), i};
    ++i;
  }
  throw std::runtime_error(path.string() + " is not a DynaHarness " + what + " (no " +
                           std::string(*std::prev(magics.end()), 8) + " header)");
}

}  // namespace dh::sim::binlog
