// The frozen embedded policy: feature vocabularies, input normalisation, the MLP, and the metadata of
// its training. Saved as a versioned weight file: a magic line, one JSON header line (format version,
// sizes, vocabularies, training facts, the payload's byte count and SHA-256), then the float32 payload.
// Loading checks all of it and names what is wrong.
#pragma once

#include <array>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dh/policy/features.hpp"
#include "dh/policy/mlp.hpp"

namespace dh::policy {

inline constexpr int kActionDims = 7;
inline constexpr int kWeightFormat = 2;

struct PolicyFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

using Action = std::array<double, kActionDims>;

struct PolicyModel {
  FeatureSpec spec;
  int chunk = 10;                  ///< actions predicted per inference
  Eigen::VectorXf feature_mean, feature_scale;
  Mlp net;
  nlohmann::json training;         ///< how it was trained (seed, data, epochs, final losses)
  std::string checksum;            ///< SHA-256 of the payload, set by save and load

  /// The next `chunk` actions for this observation, each clamped to [-1, 1]; `gripper_command` is the
  /// gripper action applied last (-1 open at the start).
  std::vector<Action> act(const Observation& obs, const std::string& instruction, double gripper_command) const;
  /// The network input for one encoded feature vector (normalised).
  Eigen::VectorXf normalise(const Eigen::VectorXf& features) const;
  /// "mlp-<first 12 hex digits of the checksum>"
  std::string version() const { return "mlp-" + checksum.substr(0, 12); }
};

/// Writes `m` to `file` (parent folders created), sets m.checksum; throws PolicyFileError.
void save_policy(PolicyModel& m, const std::filesystem::path& file);
/// Reads and verifies a weight file; throws PolicyFileError naming the file and the fault.
PolicyModel load_policy(const std::filesystem::path& file);

}  // namespace dh::policy
