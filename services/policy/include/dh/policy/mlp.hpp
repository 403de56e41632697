// A multilayer perceptron (ReLU hidden layers, linear output) with mean-squared-error gradients and an
// Adam optimizer, on Eigen, single-threaded so that training is deterministic for a seed.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace dh::policy {

struct Layer {
  Eigen::MatrixXf w;  ///< out × in
  Eigen::VectorXf b;  ///< out
};

class Mlp {
 public:
  Mlp() = default;
  /// sizes = {inputs, hidden..., outputs}; He-uniform weights drawn from `seed`.
  Mlp(const std::vector<int>& sizes, std::uint64_t seed);

  int inputs() const { return layers_.empty() ? 0 : static_cast<int>(layers_.front().w.cols()); }
  int outputs() const { return layers_.empty() ? 0 : static_cast<int>(layers_.back().w.rows()); }
  std::vector<int> sizes() const;
  const std::vector<Layer>& layers() const { return layers_; }
  std::vector<Layer>& layers() { return layers_; }

  /// Outputs for inputs `x` (one sample per column).
  Eigen::MatrixXf forward(const Eigen::MatrixXf& x) const;
  /// Mean squared error over all outputs of the batch, and its gradient per layer into `grads`.
  float loss_and_gradients(const Eigen::MatrixXf& x, const Eigen::MatrixXf& y, std::vector<Layer>& grads) const;

 private:
  std::vector<Layer> layers_;
};

class Adam {
 public:
  explicit Adam(const Mlp& net, float beta1 = 0.9f, float beta2 = 0.999f, float eps = 1e-8f);
  /// One update of `net` with `grads` at learning rate `lr`.
  void step(Mlp& net, const std::vector<Layer>& grads, float lr);

 private:
  float beta1_, beta2_, eps_;
  int t_ = 0;
  std::vector<Layer> m_, v_;
};

}  // namespace dh::policy
