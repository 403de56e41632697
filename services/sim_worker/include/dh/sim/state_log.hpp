// The seam's state log: the full physics state at the episode's start and at the start of every command,
// from which `dh replay --from-command K` (and the evolution loop's probe) restarts an episode without
// re-running what came before. Written beside the evidence (<episode>.states next to <episode>.steps).
//
// The physics state is the whole of the seam's state between control steps: the arm controller's one
// lasting state, its orientation goal, lives in mjData's userdata (osc_pose.hpp), and the safety check keeps
// none (a hold lasts the step it was raised in), so restoring these arrays and stepping on is bit-identical
// to the run that recorded them (a test says so).
//
// Binary, little-endian, append-only (a crash loses at most the record being written):
//   header  "DHSTATE2", u64 model hash, u32 MuJoCo version, u32 nq nv na nu nmocap nbody nuserdata
//   record  u32 step, u16 n, n bytes command id (empty at step 0), f64 time, f64 qpos[nq] qvel[nv]
//           act[na] ctrl[nu] qacc_warmstart[nv] mocap_pos[3 nmocap] mocap_quat[4 nmocap] userdata[nuserdata],
//           applied forces sparse: u32 k, k x (u32 index, f64 value) for qfrc_applied[nv], then xfrc_applied[6 nbody]
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace dh::sim {

/// MuJoCo's integration state and inputs: what mj_step reads that it did not compute itself.
struct PhysicsState {
  double time = 0;
  std::vector<double> qpos, qvel, act, ctrl, qacc_warmstart, mocap_pos, mocap_quat, qfrc_applied, xfrc_applied, userdata;
  /// Bit for bit (-0.0 is not 0.0, a NaN equals the same NaN): what "restores exactly" means.
  bool operator==(const PhysicsState& o) const;
};

/// The model's sizes a state must match.
struct StateShape {
  std::uint32_t nq = 0, nv = 0, na = 0, nu = 0, nmocap = 0, nbody = 0, nuserdata = 0;
  bool operator==(const StateShape&) const = default;
  /// Whether `s` has exactly these sizes.
  bool fits(const PhysicsState& s) const;
  std::string str() const;  ///< "nq 62, nv 56, ..." for messages
};

struct StateRecord {
  std::uint32_t step = 0;
  std::string command_id;  ///< the command that starts from this state; empty at step 0
  PhysicsState state;
};

struct StateLogHeader {
  std::uint64_t model_hash = 0;
  std::uint32_t mujoco_version = 0;
  StateShape shape;
};

class StateLogWriter {
 public:
  /// Creates `path` (and its folder), replacing an earlier file; throws std::runtime_error naming it.
  StateLogWriter(const std::filesystem::path& path, const StateLogHeader& header);
  ~StateLogWriter();
  StateLogWriter(const StateLogWriter&) = delete;
  StateLogWriter& operator=(const StateLogWriter&) = delete;
  /// Throws std::logic_error when the state does not have the header's shape.
  void append(const StateRecord& r);

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  StateShape shape_;
};

struct StateLog {
  StateLogHeader header;
  std::vector<StateRecord> records;  ///< complete records only (a torn last one is dropped)
  /// The record a command started from, or null.
  const StateRecord* for_command(const std::string& command_id) const;
};

/// Reads a state log; throws std::runtime_error naming the file when it is missing or not one.
StateLog read_state_log(const std::filesystem::path& path);

}  // namespace dh::sim
