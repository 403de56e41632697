// The embedded policy's parts: features, MLP gradients, training, weight files.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <random>

#include "dh/policy/demo_file.hpp"
#include "dh/policy/train.hpp"

namespace dh::policy {
namespace {

EntityState entity(const std::string& name, const std::string& kind, std::array<double, 3> p,
                   std::array<double, 3> half, double joint = 0) {
  EntityState e;
  e.name = name;
  e.kind = kind;
  e.p = p;
  e.half_extents = half;
  e.joint = joint;
  return e;
}

Observation scene(double bowl_x) {
  Observation o;
  o.ee_p = {0.1, 0.0, 0.3};
  o.ee_q = {0, 1, 0, 0};  // pointing down
  o.gripper_opening = 0.04;
  o.entities.push_back(entity("bowl", "object", {bowl_x, 0.1, 0.0}, {0.05, 0.05, 0.03}));
  o.entities.push_back(entity("cabinet_top_drawer", "drawer", {0.3, -0.2, 0.25}, {0.1, 0.01, 0.01}, 0.07));
  return o;
}

TEST(PolicyFeatures, EntitiesGoToTheirSlotsAndUnknownNamesAreIgnored) {
  FeatureSpec spec{{"bowl", "cabinet_top_drawer", "plate"}, {"bowl", "put", "the"}};
  Observation o = scene(0.4);
  o.entities.push_back(entity("never_seen", "object", {9, 9, 9}, {}));
  std::vector<float> f(static_cast<std::size_t>(spec.size()));
  encode(spec, record(o, 1), spec.slots(entity_names(o)), spec.word_indices("Put the BOWL away"), f.data());
  const int e0 = FeatureSpec::kProprio;
  EXPECT_FLOAT_EQ(f[0], 0.1f);
  EXPECT_FLOAT_EQ(f[13], 1.f);                     // the last gripper command
  EXPECT_FLOAT_EQ(f[e0 + 0], 1.f);                 // bowl present
  EXPECT_NEAR(f[e0 + 1], 0.3f, 1e-6);              // bowl x relative to the tool
  EXPECT_NEAR(f[e0 + 5 + 4], 0.07f, 1e-6);         // drawer joint
  EXPECT_FLOAT_EQ(f[e0 + 10], 0.f);                // plate absent
  const int bag = e0 + 3 * FeatureSpec::kPerEntity;
  EXPECT_EQ(std::vector<float>(f.begin() + bag, f.end()), (std::vector<float>{1, 1, 1}));
  EXPECT_EQ(words_of("Open the top-drawer, then 2 more"),
            (std::vector<std::string>{"open", "the", "top", "drawer", "then", "2", "more"}));
}

TEST(PolicyMlp, GradientsMatchFiniteDifferences) {
  Mlp net({4, 6, 3}, 7);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  Eigen::MatrixXf x(4, 5), y(3, 5);
  for (float* p : {x.data(), y.data()})
    for (int i = 0; i < (p == x.data() ? 20 : 15); ++i) p[i] = u(rng);
  std::vector<Layer> g;
  net.loss_and_gradients(x, y, g);
  const float h = 1e-3f;
  for (std::size_t l = 0; l < 2; ++l)
    for (int i = 0; i < 3; ++i) {
      float& w = net.layers()[l].w(i % net.layers()[l].w.rows(), i);
      const float keep = w;
      std::vector<Layer> unused;
      w = keep + h;
      const float up = net.loss_and_gradients(x, y, unused);
      w = keep - h;
      const float down = net.loss_and_gradients(x, y, unused);
      w = keep;
      EXPECT_NEAR((up - down) / (2 * h), g[l].w(i % net.layers()[l].w.rows(), i), 2e-3) << "layer " << l << " weight " << i;
    }
}

// Demonstrations of a reaching behaviour: move the tool towards the bowl, close the jaw when there.
std::vector<Demo> reach_demos(int count) {
  std::vector<Demo> demos;
  for (int k = 0; k < count; ++k) {
    Demo d;
    d.key = "synthetic/" + std::to_string(k);
    d.instruction = "reach the bowl";
    Observation o = scene(0.2 + 0.02 * k);
    d.entities = entity_names(o);
    for (int t = 0; t < 30; ++t) {
      const double dx = o.entities[0].p[0] - o.ee_p[0], dy = o.entities[0].p[1] - o.ee_p[1];
      Action a{std::clamp(dx / 0.05, -1.0, 1.0), std::clamp(dy / 0.05, -1.0, 1.0), 0, 0, 0, 0,
               std::hypot(dx, dy) < 0.01 ? 1.0 : -1.0};
      d.steps.push_back(record(o, d.actions.empty() ? -1.0 : d.actions.back()[6]));
      d.actions.push_back(a);
      o.ee_p[0] += 0.05 * a[0];
      o.ee_p[1] += 0.05 * a[1];
    }
    demos.push_back(std::move(d));
  }
  return demos;
}

TEST(PolicyTraining, LearnsAReachAndIsDeterministicForASeed) {
  const auto demos = reach_demos(12);
  TrainConfig c;
  c.hidden = {32, 32};
  c.chunk = 3;
  c.epochs = 60;
  c.batch = 32;
  c.learning_rate = 3e-3f;
  c.validation_share = 0.2;
  const TrainResult a = train_policy(demos, c);
  ASSERT_EQ(a.curve.size(), 60u);
  EXPECT_LT(a.curve.back().train, 0.2 * a.curve.front().train);
  EXPECT_LT(a.curve.back().validation, 0.05);
  EXPECT_GT(a.validation_demos, 0u);
  const TrainResult b = train_policy(demos, c);
  EXPECT_EQ(a.model.net.layers()[1].w, b.model.net.layers()[1].w);
  c.seed = 2;
  EXPECT_NE(a.model.net.layers()[1].w, train_policy(demos, c).model.net.layers()[1].w);
  // The policy reaches a bowl it was not shown, and closes on it.
  Observation o = scene(0.31);
  int closed_at = -1;
  for (int t = 0; t < 40 && closed_at < 0; ++t) {
    const Action act = a.model.act(o, "reach the bowl", -1)[0];
    if (act[6] > 0) closed_at = t;
    o.ee_p[0] += 0.05 * act[0];
    o.ee_p[1] += 0.05 * act[1];
  }
  EXPECT_GE(closed_at, 0);
  EXPECT_LT(std::hypot(o.ee_p[0] - 0.31, o.ee_p[1] - 0.1), 0.02);
}

TEST(PolicyTraining, RejectsInconsistentDemonstrations) {
  auto demos = reach_demos(1);
  demos[0].actions.pop_back();
  EXPECT_THROW(train_policy(demos, TrainConfig{}), std::invalid_argument);
  EXPECT_THROW(train_policy({}, TrainConfig{}), std::invalid_argument);
}

class PolicyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("dh_policy_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    TrainConfig c;
    c.hidden = {8};
    c.chunk = 2;
    c.epochs = 2;
    model_ = train_policy(reach_demos(3), c).model;
    file_ = dir_ / "p.dhp";
    save_policy(model_, file_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string bytes() const {
    std::ifstream in(file_, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
  }
  void write(const std::string& b) const { std::ofstream(file_, std::ios::binary | std::ios::trunc) << b; }
  std::string load_error() const {
    try {
      load_policy(file_);
    } catch (const PolicyFileError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_, file_;
  PolicyModel model_;
};

TEST_F(PolicyFile, RoundTripKeepsEveryWeightAndTheChecksum) {
  const PolicyModel m = load_policy(file_);
  EXPECT_EQ(m.checksum, model_.checksum);
  EXPECT_EQ(m.version(), model_.version());
  EXPECT_EQ(m.spec.entities, model_.spec.entities);
  EXPECT_EQ(m.net.layers()[0].w, model_.net.layers()[0].w);
  EXPECT_EQ(m.feature_scale, model_.feature_scale);
  const Observation o = scene(0.25);
  EXPECT_EQ(m.act(o, "reach the bowl", -1), model_.act(o, "reach the bowl", -1));
}

TEST_F(PolicyFile, ACorruptTruncatedOrMissingFileIsNamed) {
  std::string b = bytes();
  b[b.size() - 3] ^= 0x5a;
  write(b);
  EXPECT_NE(load_error().find("checksum mismatch"), std::string::npos) << load_error();
  write(b.substr(0, b.size() - 10));
  EXPECT_NE(load_error().find("truncated"), std::string::npos) << load_error();
  write("not a policy\n");
  EXPECT_NE(load_error().find("not a DynaHarness policy file"), std::string::npos) << load_error();
  std::filesystem::remove(file_);
  EXPECT_NE(load_error().find("dh train-policy"), std::string::npos) << load_error();
}

TEST_F(PolicyFile, DemonstrationsRoundTripAndABadFileIsNamed) {
  const auto demos = reach_demos(2);
  const auto file = dir_ / "demos.bin";
  save_demos(demos, file);
  const auto back = load_demos(file);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].key, demos[1].key);
  EXPECT_EQ(back[1].entities, demos[1].entities);
  EXPECT_EQ(back[1].actions, demos[1].actions);
  EXPECT_EQ(back[1].steps[7].entities, demos[1].steps[7].entities);
  EXPECT_EQ(back[1].steps[7].gripper_command, demos[1].steps[7].gripper_command);
  auto error = [&] {
    try {
      load_demos(file);
    } catch (const PolicyFileError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  std::string b;
  {
    std::ifstream in(file, std::ios::binary);
    b.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(file, std::ios::binary | std::ios::trunc) << b.substr(0, b.size() / 2);
  EXPECT_NE(error().find("truncated"), std::string::npos) << error();
  std::ofstream(file, std::ios::binary | std::ios::trunc) << "DHPOLICY 2\n";
  EXPECT_NE(error().find("not a demonstration file"), std::string::npos) << error();
}

}  // namespace
}  // namespace dh::policy
