#include "dh/sim/state_log.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "binary_log.hpp"

namespace dh::sim {
namespace {

constexpr char kMagic[8] = {'D', 'H', 'S', 'T', 'A', 'T', 'E', '2'};
constexpr const char* kWhere = "the simulator worker writes it beside the evidence; copy it there from the worker's host";
using binlog::put;

void put_dense(std::string& out, const std::vector<double>& v) {
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
}

// Applied forces are zero in every scene so far; storing only the non-zero entries keeps a record small.
void put_sparse(std::string& out, const std::vector<double>& v) {
  std::uint32_t k = 0;
  // -0.0 is kept too: restored, the state is the same bits.
  const auto stored = [](double x) { return x != 0 || std::signbit(x); };
  for (double x : v) k += stored(x);
  put(out, k);
  for (std::uint32_t i = 0; i < v.size(); ++i)
    if (stored(v[i])) {
      put(out, i);
      put(out, v[i]);
    }
}

struct Cursor : binlog::Cursor {
  bool dense(std::vector<double>& v, std::uint32_t n) {
    if (at + n * sizeof(double) > bytes.size()) return false;
    v.resize(n);
    std::memcpy(v.data(), bytes.data() + at, n * sizeof(double));
    at += n * sizeof(double);
    return true;
  }
  bool sparse(std::vector<double>& v, std::uint32_t n) {
    std::uint32_t k = 0;
    if (!get(k) || k > n) return false;
    v.assign(n, 0.0);
    for (std::uint32_t j = 0; j < k; ++j) {
      std::uint32_t i = 0;
      double x = 0;
      if (!get(i) || !get(x) || i >= n) return false;
      v[i] = x;
    }
    return true;
  }
};

}  // namespace

bool PhysicsState::operator==(const PhysicsState& o) const {
  const auto same = [](const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
  };
  return std::memcmp(&time, &o.time, sizeof time) == 0 && same(qpos, o.qpos) && same(qvel, o.qvel) &&
         same(act, o.act) && same(ctrl, o.ctrl) && same(qacc_warmstart, o.qacc_warmstart) &&
         same(mocap_pos, o.mocap_pos) && same(mocap_quat, o.mocap_quat) && same(qfrc_applied, o.qfrc_applied) &&
         same(xfrc_applied, o.xfrc_applied) && same(userdata, o.userdata);
}

bool StateShape::fits(const PhysicsState& s) const {
  return s.qpos.size() == nq && s.qvel.size() == nv && s.act.size() == na && s.ctrl.size() == nu &&
         s.qacc_warmstart.size() == nv && s.mocap_pos.size() == 3 * nmocap && s.mocap_quat.size() == 4 * nmocap &&
         s.qfrc_applied.size() == nv && s.xfrc_applied.size() == 6 * nbody && s.userdata.size() == nuserdata;
}

std::string StateShape::str() const {
  return "nq " + std::to_string(nq) + ", nv " + std::to_string(nv) + ", na " + std::to_string(na) + ", nu " +
         std::to_string(nu) + ", nmocap " + std::to_string(nmocap) + ", nbody " + std::to_string(nbody) + ", nuserdata " +
         std::to_string(nuserdata);
}

StateLogWriter::StateLogWriter(const std::filesystem::path& path, const StateLogHeader& header)
    : path_(path), shape_(header.shape) {
  std::string out(kMagic, sizeof kMagic);
  put(out, header.model_hash);
  put(out, header.mujoco_version);
  for (auto n : {shape_.nq, shape_.nv, shape_.na, shape_.nu, shape_.nmocap, shape_.nbody, shape_.nuserdata}) put(out, n);
  file_ = binlog::create(path, "state log", out);
}

StateLogWriter::~StateLogWriter() {
  if (file_) std::fclose(file_);
}

void StateLogWriter::append(const StateRecord& r) {
  if (!shape_.fits(r.state))
    throw std::logic_error("state log " + path_.string() + ": a state of another shape than the model's (" +
                           shape_.str() + ")");
  const PhysicsState& s = r.state;
  std::string out;
  put(out, r.step);
  binlog::put_string(out, r.command_id);
  put(out, s.time);
  for (const auto* v : {&s.qpos, &s.qvel, &s.act, &s.ctrl, &s.qacc_warmstart, &s.mocap_pos, &s.mocap_quat, &s.userdata})
    put_dense(out, *v);
  put_sparse(out, s.qfrc_applied);
  put_sparse(out, s.xfrc_applied);
  binlog::append(file_, out);
}

const StateRecord* StateLog::for_command(const std::string& command_id) const {
  for (const auto& r : records)
    if (r.command_id == command_id) return &r;
  return nullptr;
}

StateLog read_state_log(const std::filesystem::path& path) {
  std::string bytes;
  try {
    bytes = binlog::read(path, "state log", kMagic, kWhere);
  } catch (const std::runtime_error&) {
    char head[8] = {};
    std::ifstream(path, std::ios::binary).read(head, sizeof head);
    if (std::string(head, sizeof head) == "DHSTATE1")
      throw std::runtime_error(path.string() + " was recorded by an earlier DynaHarness (state log version 1, before the "
                               "OSC_POSE arm controller and the arm's collision capsules); its episodes cannot be "
                               "replayed on today's model: run them again");
    throw;
  }
  Cursor c{{bytes, sizeof kMagic}};
  StateLog log;
  StateShape& n = log.header.shape;
  if (!c.get(log.header.model_hash) || !c.get(log.header.mujoco_version) || !c.get(n.nq) || !c.get(n.nv) ||
      !c.get(n.na) || !c.get(n.nu) || !c.get(n.nmocap) || !c.get(n.nbody) || !c.get(n.nuserdata))
    throw std::runtime_error(path.string() + ": the state log's header is cut short");
  // A model's sizes are far below this; a corrupt header must not make a reader allocate gigabytes.
  constexpr std::uint32_t kMaxSize = 1u << 20;
  for (auto v : {n.nq, n.nv, n.na, n.nu, n.nmocap, n.nbody, n.nuserdata})
    if (v > kMaxSize) throw std::runtime_error(path.string() + ": the state log's header is corrupt (" + n.str() + ")");
  for (;;) {
    StateRecord r;
    PhysicsState& s = r.state;
    std::uint16_t len = 0;
    bool ok = c.get(r.step) && c.get(len) && c.at + len <= bytes.size();
    if (!ok) break;
    r.command_id.assign(bytes.data() + c.at, len);
    c.at += len;
    ok = c.get(s.time) && c.dense(s.qpos, n.nq) && c.dense(s.qvel, n.nv) && c.dense(s.act, n.na) &&
         c.dense(s.ctrl, n.nu) && c.dense(s.qacc_warmstart, n.nv) && c.dense(s.mocap_pos, 3 * n.nmocap) &&
         c.dense(s.mocap_quat, 4 * n.nmocap) && c.dense(s.userdata, n.nuserdata) && c.sparse(s.qfrc_applied, n.nv) &&
         c.sparse(s.xfrc_applied, 6 * n.nbody);
    if (!ok) break;
    log.records.push_back(std::move(r));
  }
  return log;
}

}  // namespace dh::sim
