#include "dh/sim/step_log.hpp"

#include <stdexcept>

#include "binary_log.hpp"

namespace dh::sim {
namespace {

constexpr char kMagic1[8] = {'D', 'H', 'S', 'T', 'E', 'P', 'S', '1'};  // no build in the header
constexpr char kMagic2[8] = {'D', 'H', 'S', 'T', 'E', 'P', 'S', '2'};  // no frames in the records
constexpr char kMagic[8] = {'D', 'H', 'S', 'T', 'E', 'P', 'S', '3'};
constexpr const char* kWhere = "the simulator worker writes it beside the evidence; copy it there from the worker's host";
using binlog::put;

}  // namespace

StepLogWriter::StepLogWriter(const std::filesystem::path& path, const StepLogHeader& header)
    : path_(path), joints_(header.joints) {
  std::string out(kMagic, sizeof kMagic);
  put(out, header.model_hash);
  put(out, header.mujoco_version);
  put(out, header.joints);
  binlog::put_string(out, header.build);
  file_ = binlog::create(path, "step log", out);
}

StepLogWriter::~StepLogWriter() {
  if (file_) std::fclose(file_);
}

void StepLogWriter::append(const StepRecord& r) {
  if (r.digest.joints.size() != 2 * joints_)
    throw std::logic_error("step log " + path_.string() + ": a digest of " + std::to_string(r.digest.joints.size()) +
                           " joint hashes for " + std::to_string(joints_) + " joints");
  std::string out;
  put(out, r.step);
  put(out, r.digest.state);
  for (auto h : r.digest.joints) put(out, h);
  for (auto h : r.digest.aux) put(out, h);
  for (double a : r.action) put(out, a);
  put(out, r.frames);
  binlog::put_string(out, r.command_id);
  binlog::append(file_, out);
}

StepLog read_step_log(const std::filesystem::path& path) {
  const auto [bytes, version] = binlog::read_versions(path, "step log", {kMagic1, kMagic2, kMagic}, kWhere);
  binlog::Cursor c{bytes, sizeof kMagic};
  StepLog log;
  std::uint16_t n = 0;
  if (!c.get(log.header.model_hash) || !c.get(log.header.mujoco_version) || !c.get(log.header.joints) ||
      (version > 0 && (!c.get(n) || c.at + n > bytes.size())))
    throw std::runtime_error(path.string() + ": the step log's header is cut short");
  log.header.build.assign(bytes.data() + c.at, n);
  c.at += n;
  for (;;) {
    StepRecord r;
    r.digest.joints.resize(2 * log.header.joints);
    std::uint16_t n = 0;
    bool ok = c.get(r.step) && c.get(r.digest.state);
    for (auto& h : r.digest.joints) ok = ok && c.get(h);
    for (auto& h : r.digest.aux) ok = ok && c.get(h);
    for (auto& a : r.action) ok = ok && c.get(a);
    if (version > 1) ok = ok && c.get(r.frames);
    ok = ok && c.get(n) && c.at + n <= bytes.size();
    if (!ok) break;
    r.command_id.assign(bytes.data() + c.at, n);
    c.at += n;
    log.records.push_back(std::move(r));
  }
  return log;
}

}  // namespace dh::sim
