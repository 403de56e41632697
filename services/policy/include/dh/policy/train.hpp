// Behaviour cloning: fits the policy MLP to demonstrations (the analytic skills' 20 Hz actions), each
// sample predicting the next `chunk` actions from one step's features. Deterministic for a seed.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dh/policy/model.hpp"

namespace dh::policy {

struct Demo {
  std::string key;                    ///< suite/task/seed
  std::string instruction;
  std::vector<std::string> entities;  ///< the order of every step record's entity values
  std::vector<StepRecord> steps;
  std::vector<Action> actions;        ///< the demonstrator's action at each step
};

struct TrainConfig {
  std::vector<int> hidden{256, 256};
  int chunk = 10;
  int epochs = 30;
  int batch = 256;
  float learning_rate = 1e-3f;        ///< at the start; cosine decay to learning_rate_final
  float learning_rate_final = 1e-5f;
  std::uint64_t seed = 1;
  double validation_share = 0.1;      ///< of the demonstrations (whole episodes), held out
};

struct EpochLoss {
  int epoch = 0;
  double train = 0, validation = 0;   ///< mean squared error per action component; validation NaN without held-out data
};

struct TrainResult {
  PolicyModel model;
  std::vector<EpochLoss> curve;
  std::size_t train_samples = 0, validation_samples = 0, train_demos = 0, validation_demos = 0;
};

/// The label chunk of step t: actions t..t+chunk-1; past the demonstration's end the hand holds still
/// with the last gripper command.
std::vector<Action> label_chunk(const Demo& d, std::size_t t, int chunk);

/// Throws std::invalid_argument for an empty or inconsistent demonstration set.
TrainResult train_policy(const std::vector<Demo>& demos, const TrainConfig& config,
                         const std::function<void(const EpochLoss&)>& on_epoch = {});

}  // namespace dh::policy
