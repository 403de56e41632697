// The perception core's bookkeeping: only episodes grounded in perception are looked at; a frame is asked
// at the first observation (or at the request, when the observation came first), then every N steps and
// never with one pending; a frame that is not the awaited one is ignored, an error frame leaves the
// request pending until the timeout asks again; a frame becomes one estimate of what was looked for and
// seen, and a seen object's place becomes its prior; an unknown task is a note, not a crash; the episode's
// result ends the looking. Its port list matches the service's README.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "dh/perception/core.hpp"
#include "dh/perception/masks.hpp"
#include "synthetic_scene.hpp"

namespace dh::perception {
namespace {

using namespace std::chrono_literals;

/// Masks a red box wherever the frame shows it (the synthetic scene's object 1), and counts its calls.
struct BoxSegmenter : Segmenter {
  const synth::Rendered* shown = nullptr;
  int calls = 0;
  std::vector<Mask> segment(const cv::Mat&, const std::vector<EntityAppearance>& entities) override {
    ++calls;
    std::vector<Mask> out;
    for (const auto& e : entities) out.push_back({e.entity, synth::id_mask(*shown, 1), 1.0});
    return out;
  }
};

struct PerceptionCoreTest : ::testing::Test {
  synth::Rendered rendered = [] {
    synth::Scene s;
    s.world_from_camera = synth::workcell_camera();
    s.boxes = {
        synth::Box{Eigen::Vector3d(0.05, -0.02, 0.03), 0, Eigen::Vector3d(0.06, 0.06, 0.06), {200, 40, 40}}};
    return synth::render(s);
  }();
  BoxSegmenter segmenter;
  std::vector<std::pair<std::string, std::uint32_t>> scenes_loaded;
  Clock::time_point t0{};
  std::unique_ptr<PerceptionCore> core;

  void SetUp() override {
    segmenter.shown = &rendered;
    CloudParams cloud;
    cloud.support_z = 0;
    core = std::make_unique<PerceptionCore>(
        CoreSettings{"workcell", 10, 2000ms},
        [this](const std::string& suite, std::uint32_t task) {
          if (suite != "goal") throw std::invalid_argument("no suite '" + suite + "'");
          scenes_loaded.emplace_back(suite, task);
          LookFor box;
          box.appearance = {"red_box", {{200, 40, 40}}, 40, 0};
          box.size = Eigen::Vector3d(0.06, 0.06, 0.06);
          return std::vector<LookFor>{box};
        },
        [](const std::string&, std::uint32_t) { return std::vector<PartModel>{}; }, segmenter, cloud);
  }
  PerceptionEffects start(std::uint32_t channel, const std::string& episode,
                          const std::string& grounding = "perception") {
    return core->on_episode(channel, episode, grounding, "goal", 3, t0);
  }
  PerceptionEffects frame(const FrameAsk& ask, const std::string& episode, std::uint32_t step,
                          const std::string& error = "") {
    return core->on_frame({ask.channel, ask.request_id, episode, ask.camera, error, step, 1.5},
                          [this] { return rendered.frame; });
  }
};

TEST_F(PerceptionCoreTest, AnEpisodeGroundedInStateIsNotLookedAt) {
  EXPECT_TRUE(start(0, "ep", "state").asks.empty());
  EXPECT_TRUE(core->on_observation(0, "ep", 0, t0).asks.empty());
  EXPECT_TRUE(scenes_loaded.empty()) << "a scene was loaded for an episode nobody looks at";
}

TEST_F(PerceptionCoreTest, FramesAreAskedAtTheFirstObservationThenEveryNStepsNeverWithOnePending) {
  EXPECT_TRUE(start(0, "ep").asks.empty()) << "no observation yet";
  const auto first = core->on_observation(0, "ep", 0, t0);
  ASSERT_EQ(first.asks.size(), 1u);
  EXPECT_EQ(first.asks[0].camera, "workcell");
  EXPECT_TRUE(core->on_observation(0, "ep", 12, t0).asks.empty()) << "asked again with one pending";
  ASSERT_TRUE(frame(first.asks[0], "ep", 0).estimate);
  EXPECT_TRUE(core->on_observation(0, "ep", 9, t0).asks.empty()) << "asked before N steps passed";
  const auto next = core->on_observation(0, "ep", 10, t0);
  ASSERT_EQ(next.asks.size(), 1u);
  EXPECT_NE(next.asks[0].request_id, first.asks[0].request_id);
  EXPECT_TRUE(core->on_observation(1, "other", 0, t0).asks.empty()) << "a channel without a request";
}

TEST_F(PerceptionCoreTest, AnObservationBeforeTheRequestIsAnsweredWhenTheRequestComes) {
  EXPECT_TRUE(core->on_observation(2, "ep", 0, t0).asks.empty());
  const auto fx = start(2, "ep");
  ASSERT_EQ(fx.asks.size(), 1u);
  EXPECT_EQ(fx.asks[0].channel, 2u);
  EXPECT_TRUE(start(2, "ep").asks.empty()) << "the same request again asked again";
}

TEST_F(PerceptionCoreTest, AFrameBecomesAnEstimateOfWhatWasLookedForAndSeen) {
  start(0, "ep");
  const auto ask = core->on_observation(0, "ep", 0, t0).asks.at(0);
  const auto fx = frame(ask, "ep", 0);
  ASSERT_TRUE(fx.estimate);
  const SceneOut& e = *fx.estimate;
  EXPECT_EQ(e.channel, 0u);
  EXPECT_EQ(e.episode_id, "ep");
  EXPECT_EQ(e.camera, "workcell");
  EXPECT_EQ(e.stamp_s, 1.5);
  EXPECT_EQ(e.looked_for, std::vector<std::string>{"red_box"});
  ASSERT_EQ(e.seen.size(), 1u);
  EXPECT_LT((e.seen[0].centroid - Eigen::Vector3d(0.05, -0.02, 0.03)).norm(), 0.01)
      << e.seen[0].centroid.transpose();
  EXPECT_GE(e.latency_ms, 0.0);
  EXPECT_TRUE(frame(ask, "ep", 0).notes.empty() && !frame(ask, "ep", 0).estimate)
      << "one frame answered twice";
}

TEST_F(PerceptionCoreTest, WithAPartsCameraEachLookAsksItTooAndItsFrameIsAnEstimateOfTheParts) {
  // A drawer in front of the fixture camera's view: its boxes where the rendered frame has nothing.
  PartModel drawer;
  drawer.name = "unit_drawer";
  drawer.world_from_rest = Eigen::Isometry3d(Eigen::Translation3d(0.2, 0.3, 0.05));
  drawer.axis = -Eigen::Vector3d::UnitX();
  drawer.hi = 0.16;
  drawer.boxes = {BodyBox{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, 0.1, 0.03), 0}};
  drawer.riders = {{"unit_drawer", Eigen::Vector3d(-0.1, 0, 0)}};
  CoreSettings settings{"workcell", 10, 2000ms};
  settings.parts_camera = "front";
  std::vector<std::string> parts_asked;
  PerceptionCore with_parts(
      settings, [](const std::string&, std::uint32_t) { return std::vector<LookFor>{}; },
      [&](const std::string& suite, std::uint32_t) {
        parts_asked.push_back(suite);
        return std::vector<PartModel>{drawer};
      },
      segmenter, CloudParams{});
  with_parts.on_episode(0, "ep", "perception", "goal", 3, t0);
  EXPECT_EQ(parts_asked, std::vector<std::string>{"goal"});
  const auto asks = with_parts.on_observation(0, "ep", 0, t0).asks;
  ASSERT_EQ(asks.size(), 2u);
  EXPECT_EQ(asks[0].camera, "workcell");
  EXPECT_EQ(asks[1].camera, "front");
  const auto answer = [&](const FrameAsk& a, std::uint32_t step) {
    return with_parts.on_frame({a.channel, a.request_id, "ep", a.camera, "", step, 1.5}, [this] { return rendered.frame; });
  };
  const auto objects = answer(asks[0], 0);
  ASSERT_TRUE(objects.estimate) << "the objects do not wait for the parts";
  EXPECT_TRUE(objects.estimate->parts.empty());
  // The next look: the parts frame is still pending, so only the objects camera is asked.
  const auto next = with_parts.on_observation(0, "ep", 10, t0).asks;
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].camera, "workcell");
  const auto parts = answer(asks[1], 1);
  ASSERT_TRUE(parts.estimate);
  EXPECT_EQ(parts.estimate->camera, "front");
  EXPECT_TRUE(parts.estimate->looked_for.empty()) << "a parts frame looks for no objects";
  ASSERT_EQ(parts.estimate->parts.size(), 1u);
  EXPECT_EQ(parts.estimate->parts[0].name, "unit_drawer");
  EXPECT_EQ(parts.estimate->parts[0].confidence, 0) << "nothing of the drawer is in the frame";
  ASSERT_EQ(parts.estimate->parts[0].riders.size(), 1u);
  // Unanswered, a frame is asked again by itself.
  const auto again = with_parts.on_tick(t0 + 2500ms).asks;
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].camera, "workcell");
}

TEST_F(PerceptionCoreTest, AFrameThatCannotBeMadeIsAnEstimateThatSeesNothingAndSaysWhy) {
  start(0, "ep");
  const auto ask = core->on_observation(0, "ep", 0, t0).asks.at(0);
  const auto fx = core->on_frame({0, ask.request_id, "ep", "workcell", "", 0, 0},
                                 []() -> RgbdFrame { throw std::invalid_argument("depth of 3 bytes"); });
  ASSERT_TRUE(fx.estimate);
  EXPECT_TRUE(fx.estimate->seen.empty());
  EXPECT_EQ(fx.estimate->looked_for.size(), 1u);
  ASSERT_EQ(fx.notes.size(), 1u);
  EXPECT_NE(fx.notes[0].text.find("depth of 3 bytes"), std::string::npos) << fx.notes[0].text;
}

TEST_F(PerceptionCoreTest, AnErrorFrameLeavesTheRequestPendingUntilTheTimeoutAsksAgain) {
  start(0, "ep");
  const auto ask = core->on_observation(0, "ep", 5, t0).asks.at(0);
  EXPECT_FALSE(frame({0, "workcell", "perception-999"}, "ep", 5).estimate) << "another request's frame";
  const auto failed = frame(ask, "ep", 5, "no OpenGL context");
  EXPECT_FALSE(failed.estimate);
  ASSERT_EQ(failed.notes.size(), 1u);
  EXPECT_NE(failed.notes[0].text.find("no OpenGL context"), std::string::npos);
  EXPECT_FALSE(frame(ask, "another-episode", 5).estimate) << "a frame of another episode was taken";
  EXPECT_EQ(segmenter.calls, 0);
  EXPECT_TRUE(core->on_tick(t0 + 1999ms).asks.empty());
  const auto again = core->on_tick(t0 + 2000ms);
  ASSERT_EQ(again.asks.size(), 1u);
  EXPECT_NE(again.asks[0].request_id, ask.request_id);
  EXPECT_TRUE(frame(again.asks[0], "ep", 5).estimate);
}

TEST_F(PerceptionCoreTest, ARobotStandingStillIsLookedAtAgainAtItsStep) {
  start(0, "ep");
  const auto first = core->on_observation(0, "ep", 40, t0).asks.at(0);
  EXPECT_TRUE(core->on_tick(t0 + 300ms).asks.empty()) << "asked again with one pending";
  ASSERT_TRUE(frame(first, "ep", 40).estimate);
  EXPECT_TRUE(core->on_tick(t0 + 249ms).asks.empty()) << "the robot has not stood still long enough";
  const auto still = core->on_tick(t0 + 250ms);
  ASSERT_EQ(still.asks.size(), 1u);
  EXPECT_NE(still.asks[0].request_id, first.request_id);
  const auto seen = frame(still.asks[0], "ep", 40);
  ASSERT_TRUE(seen.estimate);
  EXPECT_EQ(seen.estimate->step, 40u) << "a frame of the same step";
}

TEST_F(PerceptionCoreTest, AnUnknownTaskIsANoteAndTheResultEndsTheLooking) {
  const auto bad = core->on_episode(0, "ep", "perception", "no-such-suite", 0, t0);
  ASSERT_EQ(bad.notes.size(), 1u);
  EXPECT_EQ(bad.notes[0].level, Note::Level::Error);
  EXPECT_NE(bad.notes[0].text.find("no suite 'no-such-suite'"), std::string::npos) << bad.notes[0].text;
  EXPECT_TRUE(core->on_observation(0, "ep", 0, t0).asks.empty());

  start(1, "ep1");
  core->on_result(1, "someone-else");
  EXPECT_EQ(core->on_observation(1, "ep1", 0, t0).asks.size(), 1u)
      << "another episode's result ended this one";
  core->on_result(1, "ep1");
  EXPECT_TRUE(core->on_tick(t0 + 10s).asks.empty()) << "an ended episode asked again";
}

TEST(PerceptionPorts, MatchTheServiceReadme) {
  const char* home = std::getenv("DH_HOME");
  ASSERT_TRUE(home) << "DH_HOME names the checkout";
  EXPECT_EQ(port_table(std::filesystem::path(home) / "services/perception/README.md"),
            port_table(PerceptionCore::ports()));
}

}  // namespace
}  // namespace dh::perception
