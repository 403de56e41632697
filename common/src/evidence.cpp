#include "dh/common/evidence.hpp"

#include <chrono>
#include <fstream>
#include <stdexcept>

namespace dh {

EvidenceWriter::EvidenceWriter(std::filesystem::path path) : path_(std::move(path)) {
  std::error_code ec;
  if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path(), ec);
  file_ = std::fopen(path_.c_str(), "a");
  if (!file_)
    throw std::runtime_error("cannot open evidence file " + path_.string() +
                             " for appending (check DH_RUNS_DIR and its permissions)");
}

EvidenceWriter::~EvidenceWriter() {
  if (file_) std::fclose(file_);
}

void EvidenceWriter::append(const std::string& component, const std::string& kind,
                            nlohmann::json fields) {
  {
    std::lock_guard lock(mutex_);
    write(component, kind, fields);
  }
  if (tap_) tap_(kind, fields);
}

void EvidenceWriter::write(const std::string& component, const std::string& kind, nlohmann::json& fields) {
  fields["seq"] = seq_++;
  fields["component"] = component;
  fields["kind"] = kind;
  fields["t_wall_ns"] = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
  const std::string line = fields.dump() + "\n";
  std::fwrite(line.data(), 1, line.size(), file_);
  std::fflush(file_);
}

std::vector<nlohmann::json> read_evidence(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read evidence file " + path.string());
  std::vector<nlohmann::json> out;
  std::string line;
  while (std::getline(in, line)) {
    auto j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (!j.is_discarded()) out.push_back(std::move(j));
  }
  return out;
}

}  // namespace dh
