#include "dh/policy/mlp.hpp"

#include <cmath>
#include <random>
#include <stdexcept>

namespace dh::policy {

Mlp::Mlp(const std::vector<int>& sizes, std::uint64_t seed) {
  if (sizes.size() < 2) throw std::invalid_argument("an MLP needs at least an input and an output size");
  std::mt19937_64 rng(seed);
  for (std::size_t i = 0; i + 1 < sizes.size(); ++i) {
    const int in = sizes[i], out = sizes[i + 1];
    if (in <= 0 || out <= 0) throw std::invalid_argument("MLP layer sizes must be positive");
    std::uniform_real_distribution<float> u(-std::sqrt(6.f / in), std::sqrt(6.f / in));
    Layer l{Eigen::MatrixXf(out, in), Eigen::VectorXf::Zero(out)};
    for (int c = 0; c < in; ++c)
      for (int r = 0; r < out; ++r) l.w(r, c) = u(rng);
    layers_.push_back(std::move(l));
  }
}

std::vector<int> Mlp::sizes() const {
  std::vector<int> s;
  if (layers_.empty()) return s;
  s.push_back(inputs());
  for (const auto& l : layers_) s.push_back(static_cast<int>(l.w.rows()));
  return s;
}

Eigen::MatrixXf Mlp::forward(const Eigen::MatrixXf& x) const {
  Eigen::MatrixXf h = x;
  for (std::size_t i = 0; i < layers_.size(); ++i) {
    Eigen::MatrixXf z = layers_[i].w * h;
    z.colwise() += layers_[i].b;
    h = i + 1 < layers_.size() ? Eigen::MatrixXf(z.cwiseMax(0.f)) : z;
  }
  return h;
}

float Mlp::loss_and_gradients(const Eigen::MatrixXf& x, const Eigen::MatrixXf& y, std::vector<Layer>& grads) const {
  const std::size_t n = layers_.size();
  std::vector<Eigen::MatrixXf> act(n + 1);  // act[i] is the input of layer i; act[n] the output
  act[0] = x;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::MatrixXf z = layers_[i].w * act[i];
    z.colwise() += layers_[i].b;
    act[i + 1] = i + 1 < n ? Eigen::MatrixXf(z.cwiseMax(0.f)) : z;
  }
  const Eigen::MatrixXf diff = act[n] - y;
  const float count = static_cast<float>(diff.size());
  Eigen::MatrixXf delta = diff * (2.f / count);
  grads.resize(n);
  for (std::size_t i = n; i-- > 0;) {
    grads[i].w.noalias() = delta * act[i].transpose();
    grads[i].b = delta.rowwise().sum();
    if (i > 0) {
      Eigen::MatrixXf back = layers_[i].w.transpose() * delta;
      delta = back.cwiseProduct((act[i].array() > 0.f).cast<float>().matrix());
    }
  }
  return diff.squaredNorm() / count;
}

Adam::Adam(const Mlp& net, float beta1, float beta2, float eps) : beta1_(beta1), beta2_(beta2), eps_(eps) {
  for (const auto& l : net.layers()) {
    m_.push_back({Eigen::MatrixXf::Zero(l.w.rows(), l.w.cols()), Eigen::VectorXf::Zero(l.b.size())});
    v_.push_back(m_.back());
  }
}

void Adam::step(Mlp& net, const std::vector<Layer>& grads, float lr) {
  ++t_;
  const float c1 = 1.f - std::pow(beta1_, static_cast<float>(t_));
  const float c2 = 1.f - std::pow(beta2_, static_cast<float>(t_));
  auto update = [&](auto& param, const auto& g, auto& m, auto& v) {
    m = beta1_ * m + (1.f - beta1_) * g;
    v = beta2_ * v + (1.f - beta2_) * g.cwiseProduct(g);
    param.array() -= lr * (m.array() / c1) / ((v.array() / c2).sqrt() + eps_);
  };
  for (std::size_t i = 0; i < grads.size(); ++i) {
    update(net.layers()[i].w, grads[i].w, m_[i].w, v_[i].w);
    update(net.layers()[i].b, grads[i].b, m_[i].b, v_[i].b);
  }
}

}  // namespace dh::policy
