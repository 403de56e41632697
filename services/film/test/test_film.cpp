// dh film on Figure 3's case as this physics has it (goal-swap 5 seed 21, recorded in process): the strip
// shows the refused push, the substituted pick and place and the latched verdict, in labelled frames of
// different pictures; a video holds every step; bad input is named.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <unistd.h>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/film/film.hpp"
#include "dh/inproc/stack.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {

struct Film : ::testing::Test {
  static void SetUpTestSuite() {
    dir = new fs::path(fs::path(::testing::TempDir()) / ("dh_film_test_" + std::to_string(getpid())));
    fs::remove_all(*dir);
    inproc::Stack stack(paths::config_dir());
    const auto suites = load_suites(paths::config_dir());
    success = stack.run(find_task(suites, "goal-swap", 5), 21, "full", *dir / "ep.jsonl").success;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir);
    delete dir;
  }
  static film::FilmOptions options() {
    film::FilmOptions o;
    o.config_dir = paths::config_dir();
    o.strip = *dir / "strip.png";
    return o;
  }
  static fs::path* dir;
  static bool success;
};
fs::path* Film::dir = nullptr;
bool Film::success = false;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_F(Film, TheStripShowsTheRefusedPushTheSubstitutedPickAndPlaceAndTheLatchedVerdict) {
  ASSERT_TRUE(success);
  const film::FilmResult r = film::film(*dir / "ep.jsonl", options());
  EXPECT_TRUE(r.replay_identical);
  ASSERT_GE(r.frames.size(), 3u);
  ASSERT_LE(r.frames.size(), 8u);

  const auto& first = r.frames.front();
  EXPECT_EQ(first.step, 0u);
  EXPECT_TRUE(contains(first.event, "push refused: the jaw is too narrow")) << first.event;
  EXPECT_EQ(first.capability, "push -> pick_place");
  EXPECT_EQ(first.decision, "substitute");
  bool carried = false;
  for (const auto& f : r.frames)
    carried |= f.step > 0 && f.capability == "pick_place" && f.decision == "substitute" &&
               contains(f.event, "pick_place running");
  EXPECT_TRUE(carried) << "a frame of the substituted pick and place at work";
  const auto& last = r.frames.back();
  EXPECT_TRUE(contains(last.event, "verdict latched: success")) << last.event;
  EXPECT_EQ(last.decision, "stop_success");
  for (std::size_t i = 1; i < r.frames.size(); ++i) EXPECT_LT(r.frames[i - 1].step, r.frames[i].step);
  EXPECT_EQ(film::caption(last)[0], "step " + std::to_string(last.step) + " | pick_place");

  // The strip: a title band and one 320 x 240 picture per frame, and the pictures differ (the plate moved).
  const cv::Mat strip = cv::imread((*dir / "strip.png").string());
  ASSERT_FALSE(strip.empty());
  const int cols = static_cast<int>(std::min<std::size_t>(5, r.frames.size()));
  EXPECT_EQ(strip.cols, 6 + cols * (320 + 6));
  const int title_h = 2 * 18 + 6;
  const cv::Mat a = strip(cv::Rect(6, title_h, 320, 240));
  const cv::Mat b = strip(cv::Rect(6 + (cols - 1) * 326, title_h, 320, 240));
  EXPECT_GT(cv::norm(a, b, cv::NORM_L1) / (320.0 * 240.0), 1.0) << "the first and the last picture are the same";
  EXPECT_GT(cv::norm(a, cv::NORM_INF), 0.0) << "a black picture";
}

TEST_F(Film, ChosenStepsAreLabelledAndAVideoHoldsEveryStep) {
  ASSERT_TRUE(success);
  auto o = options();
  o.steps = std::vector<std::uint32_t>{100, 0, 100};
  o.camera = "workcell";
  o.video = *dir / "ep.webm";
  const film::FilmResult r = film::film(*dir / "ep.jsonl", o);
  ASSERT_EQ(r.frames.size(), 2u);
  EXPECT_EQ(r.frames[0].step, 0u);
  EXPECT_EQ(r.frames[1].step, 100u);
  EXPECT_EQ(r.frames[1].capability, "pick_place");
  EXPECT_EQ(r.frames[1].event, "pick_place running");
  EXPECT_EQ(r.video_frames, r.steps + 1);
  cv::VideoCapture video((*dir / "ep.webm").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  cv::Mat frame;
  int read = 0, width = 0;
  for (; video.read(frame); ++read) width = frame.cols;
  EXPECT_EQ(read, static_cast<int>(r.video_frames));
  EXPECT_EQ(width, 320);
}

TEST_F(Film, BadInputIsNamed) {
  ASSERT_TRUE(success);
  const auto message = [](auto&& f) {
    try {
      f();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  auto o = options();
  EXPECT_TRUE(contains(message([&] { film::film(*dir / "none.jsonl", o); }), "none.jsonl: no such file"));
  o.steps = std::vector<std::uint32_t>{100000};
  EXPECT_TRUE(contains(message([&] { film::film(*dir / "ep.jsonl", o); }), "step 100000 is past the episode's last"));
  o.steps.reset();
  o.camera = "ceiling";
  EXPECT_TRUE(contains(message([&] { film::film(*dir / "ep.jsonl", o); }), "ceiling"));
  o.camera = "agentview";
  o.video = *dir / "ep.gif";
  EXPECT_TRUE(contains(message([&] { film::film(*dir / "ep.jsonl", o); }), ".webm (VP8) or .mp4"));
  // An episode cut before its end has no verdict to show.
  o.video.clear();
  std::ifstream in(*dir / "ep.jsonl");
  std::ofstream cut(*dir / "cut.jsonl");
  for (std::string line; std::getline(in, line);)
    if (!contains(line, "\"episode_end\"")) cut << line << "\n";
  cut.close();
  fs::copy_file(*dir / "ep.steps", *dir / "cut.steps", fs::copy_options::overwrite_existing);
  EXPECT_TRUE(contains(message([&] { film::film(*dir / "cut.jsonl", o); }), "no episode_end record"));
}
