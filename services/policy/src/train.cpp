#include "dh/policy/train.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>
#include <set>
#include <stdexcept>

namespace dh::policy {

std::vector<Action> label_chunk(const Demo& d, std::size_t t, int chunk) {
  std::vector<Action> out;
  for (int k = 0; k < chunk; ++k) {
    const std::size_t i = t + static_cast<std::size_t>(k);
    if (i < d.actions.size()) {
      out.push_back(d.actions[i]);
    } else {
      Action still{};
      still[6] = d.actions.back()[6];
      out.push_back(still);
    }
  }
  return out;
}

namespace {

struct Samples {
  Eigen::MatrixXf x, y;  // one column per sample
};

Samples build(const std::vector<const Demo*>& demos, const FeatureSpec& spec, int chunk) {
  std::size_t n = 0;
  for (const Demo* d : demos) n += d->steps.size();
  Samples s{Eigen::MatrixXf(spec.size(), static_cast<Eigen::Index>(n)),
            Eigen::MatrixXf(chunk * kActionDims, static_cast<Eigen::Index>(n))};
  Eigen::Index col = 0;
  for (const Demo* d : demos) {
    const auto slots = spec.slots(d->entities);
    const auto words = spec.word_indices(d->instruction);
    for (std::size_t t = 0; t < d->steps.size(); ++t, ++col) {
      encode(spec, d->steps[t], slots, words, s.x.col(col).data());
      const auto lab = label_chunk(*d, t, chunk);
      for (int k = 0; k < chunk; ++k)
        for (int a = 0; a < kActionDims; ++a) s.y(k * kActionDims + a, col) = static_cast<float>(lab[k][a]);
    }
  }
  return s;
}

double mean_loss(const Mlp& net, const Eigen::MatrixXf& x, const Eigen::MatrixXf& y) {
  double sum = 0;
  for (Eigen::Index c = 0; c < x.cols(); c += 4096) {
    const Eigen::Index w = std::min<Eigen::Index>(4096, x.cols() - c);
    sum += (net.forward(x.middleCols(c, w)) - y.middleCols(c, w)).squaredNorm();
  }
  return sum / static_cast<double>(y.size());
}

}  // namespace

TrainResult train_policy(const std::vector<Demo>& demos, const TrainConfig& cfg,
                         const std::function<void(const EpochLoss&)>& on_epoch) {
  if (demos.empty()) throw std::invalid_argument("no demonstrations to train on");
  if (cfg.chunk < 1 || cfg.epochs < 1 || cfg.batch < 1)
    throw std::invalid_argument("chunk, epochs and batch must be at least 1");
  std::set<std::string> entities, words;
  for (const auto& d : demos) {
    if (d.steps.size() != d.actions.size() || d.steps.empty())
      throw std::invalid_argument("demonstration " + d.key + " has " + std::to_string(d.steps.size()) +
                                  " observations and " + std::to_string(d.actions.size()) + " actions");
    entities.insert(d.entities.begin(), d.entities.end());
    for (const auto& w : words_of(d.instruction)) words.insert(w);
  }
  TrainResult r;
  PolicyModel& m = r.model;
  m.spec.entities.assign(entities.begin(), entities.end());
  m.spec.words.assign(words.begin(), words.end());
  m.chunk = cfg.chunk;

  // Held-out episodes, drawn from the seed.
  std::mt19937_64 rng(cfg.seed);
  std::vector<const Demo*> train, held;
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& d : demos) (u(rng) < cfg.validation_share ? held : train).push_back(&d);
  if (train.empty()) std::swap(train, held);
  Samples tr = build(train, m.spec, cfg.chunk);
  Samples va = build(held, m.spec, cfg.chunk);
  r.train_demos = train.size();
  r.validation_demos = held.size();
  r.train_samples = static_cast<std::size_t>(tr.x.cols());
  r.validation_samples = static_cast<std::size_t>(va.x.cols());

  // Inputs standardised with the training set's statistics; constant features pass through unscaled.
  const auto n = static_cast<float>(tr.x.cols());
  m.feature_mean = tr.x.rowwise().sum() / n;
  m.feature_scale = ((tr.x.colwise() - m.feature_mean).array().square().rowwise().sum() / n).sqrt().matrix();
  for (Eigen::Index i = 0; i < m.feature_scale.size(); ++i)
    if (m.feature_scale[i] < 1e-4f) m.feature_scale[i] = 1.f;
  auto standardise = [&](Eigen::MatrixXf& x) {
    x = (x.colwise() - m.feature_mean).array().colwise() / m.feature_scale.array();
  };
  standardise(tr.x);
  standardise(va.x);

  std::vector<int> sizes{m.spec.size()};
  sizes.insert(sizes.end(), cfg.hidden.begin(), cfg.hidden.end());
  sizes.push_back(cfg.chunk * kActionDims);
  m.net = Mlp(sizes, cfg.seed);
  Adam adam(m.net);
  std::vector<Layer> grads;
  std::vector<Eigen::Index> order(static_cast<std::size_t>(tr.x.cols()));
  std::iota(order.begin(), order.end(), 0);
  const Eigen::Index batches = (tr.x.cols() + cfg.batch - 1) / cfg.batch;
  const double total_steps = static_cast<double>(batches) * cfg.epochs;
  Eigen::MatrixXf bx(tr.x.rows(), cfg.batch), by(tr.y.rows(), cfg.batch);
  long step = 0;
  for (int epoch = 1; epoch <= cfg.epochs; ++epoch) {
    std::shuffle(order.begin(), order.end(), rng);
    double sum = 0;
    for (Eigen::Index b = 0; b < batches; ++b) {
      const Eigen::Index start = b * cfg.batch;
      const Eigen::Index w = std::min<Eigen::Index>(cfg.batch, tr.x.cols() - start);
      bx.resize(tr.x.rows(), w);
      by.resize(tr.y.rows(), w);
      for (Eigen::Index i = 0; i < w; ++i) {
        bx.col(i) = tr.x.col(order[static_cast<std::size_t>(start + i)]);
        by.col(i) = tr.y.col(order[static_cast<std::size_t>(start + i)]);
      }
      const double progress = static_cast<double>(step++) / total_steps;
      const float lr = cfg.learning_rate_final + 0.5f * (cfg.learning_rate - cfg.learning_rate_final) *
                                                     static_cast<float>(1 + std::cos(std::numbers::pi * progress));
      sum += m.net.loss_and_gradients(bx, by, grads) * static_cast<double>(w);
      adam.step(m.net, grads, lr);
    }
    EpochLoss e{epoch, sum / static_cast<double>(tr.x.cols()),
                va.x.cols() ? mean_loss(m.net, va.x, va.y) : std::numeric_limits<double>::quiet_NaN()};
    r.curve.push_back(e);
    if (on_epoch) on_epoch(e);
  }
  const double final_validation = r.curve.back().validation;
  m.training = {{"seed", cfg.seed},
                {"epochs", cfg.epochs},
                {"batch", cfg.batch},
                {"chunk", cfg.chunk},
                {"learning_rate", static_cast<double>(cfg.learning_rate)},
                {"learning_rate_final", static_cast<double>(cfg.learning_rate_final)},
                {"validation_share", cfg.validation_share},
                {"hidden", cfg.hidden},
                {"train_demos", r.train_demos},
                {"validation_demos", r.validation_demos},
                {"train_samples", r.train_samples},
                {"validation_samples", r.validation_samples},
                {"final_train_loss", r.curve.back().train},
                {"final_validation_loss", std::isnan(final_validation) ? nlohmann::json(nullptr)
                                                                       : nlohmann::json(final_validation)}};
  return r;
}

}  // namespace dh::policy
