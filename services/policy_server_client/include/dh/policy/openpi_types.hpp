// What an openpi policy server serving a LIBERO config (pi05_libero, pi0_libero) is asked and answers:
// two RGB cameras, the 8-d proprioceptive state and the instruction in; a chunk of 7-d actions out.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace dh::policy {

/// openpi's LIBERO examples resize both cameras with padding to this square (see resize_with_pad).
inline constexpr int kOpenpiImageSide = 224;
/// eef position (3), eef orientation as axis-angle (3), gripper finger qpos (2).
inline constexpr int kOpenpiStateDims = 8;
/// Δposition (3), Δaxis-angle (3), gripper (−1 open, +1 close): robosuite's OSC_POSE delta action.
inline constexpr int kOpenpiActionDims = 7;

/// An RGB image, row-major height × width × 3 bytes (no row padding).
struct CameraImage {
  std::string name;  ///< for messages only, e.g. "agentview"
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};

/// One observation for the policy (openpi's LIBERO observation dict).
struct PolicyQuery {
  CameraImage agent_view;                       ///< "observation/image"
  CameraImage wrist;                            ///< "observation/wrist_image"
  std::array<float, kOpenpiStateDims> state{};  ///< "observation/state"
  std::string prompt;                           ///< "prompt": the instruction
};

/// The policy's answer: H ≥ 1 actions to execute in order (H = 10 for pi05_libero).
struct ActionChunk {
  std::vector<std::array<double, kOpenpiActionDims>> actions;
  double infer_ms = 0;       ///< the server's "server_timing"/"infer_ms"; 0 when it does not say
  double round_trip_ms = 0;  ///< the whole call as the client measured it (a reconnection included)
};

}  // namespace dh::policy
