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
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(std::string("no ") + what + " " + path.string() + " (" + missing_hint + ")");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof magic || std::memcmp(bytes.data(), magic, sizeof magic) != 0)
    throw std::runtime_error(path.string() + " is not a DynaHarness " + what + " (no " + std::string(magic, 8) +
                             " header)");
  return bytes;
}

}  // namespace dh::sim::binlog
