// The seam's step log: for each step of an episode, the action applied to reach it and a digest of the
// physics state after it. Written beside the episode's evidence (<episode>.steps next to <episode>.jsonl),
// read by `dh replay`, which applies the same actions to the same reset and compares the digests.
//
// Binary, little-endian, append-only (a crash loses at most the record being written):
//   header  "DHSTEPS2", u64 model hash, u32 MuJoCo version, u32 joints J, u16 n, n bytes build
//           (the simulator's, as build_info() says; "DHSTEPS1" files, written before it, have none)
//   record  u32 step, u64 state hash, u32 per joint [qpos hash, qvel hash] x J,
//           u32 [time, act, ctrl, qacc_warmstart] hashes, f64 action x 7, u16 n, n bytes command id
// Step 0 (the reset) has no command and a zero action.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace dh::sim {

/// The physics state in hashes: one over all of it, and one per joint and quantity to say where two differ.
struct StateDigest {
  std::uint64_t state = 0;                ///< time, qpos, qvel, act, ctrl, qacc_warmstart (FNV-1a 64)
  std::vector<std::uint32_t> joints;      ///< per joint: qpos slice, qvel slice (FNV-1a 32)
  std::array<std::uint32_t, 4> aux{};     ///< time, act, ctrl, qacc_warmstart
  bool operator==(const StateDigest&) const = default;
};

struct StepRecord {
  std::uint32_t step = 0;
  std::string command_id;        ///< whose action was applied to reach this step; empty at step 0
  std::array<double, 7> action{};  ///< as admitted, before the physics clamps it
  StateDigest digest;
  /// The scene estimates the perceived world of the action's capability had taken in (perception
  /// grounding; 0 otherwise, and in DHSTEPS1 and 2 files).
  std::uint32_t frames = 0;
};

struct StepLogHeader {
  std::uint64_t model_hash = 0;
  std::uint32_t mujoco_version = 0;
  std::uint32_t joints = 0;
  std::string build;  ///< the build of the simulator that wrote it; empty in a DHSTEPS1 file
};

class StepLogWriter {
 public:
  /// Creates `path` (and its folder), replacing an earlier file; throws std::runtime_error naming it.
  StepLogWriter(const std::filesystem::path& path, const StepLogHeader& header);
  ~StepLogWriter();
  StepLogWriter(const StepLogWriter&) = delete;
  StepLogWriter& operator=(const StepLogWriter&) = delete;
  void append(const StepRecord& r);

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint32_t joints_;
};

struct StepLog {
  StepLogHeader header;
  std::vector<StepRecord> records;  ///< complete records only (a torn last one is dropped)
};

/// Reads a step log; throws std::runtime_error naming the file when it is missing or not one.
StepLog read_step_log(const std::filesystem::path& path);

}  // namespace dh::sim
