// HttpSegmenter against fake_segment_server.py on 127.0.0.1: valid replies in each mask encoding, and
// every failure the node must report (HTTP error, non-JSON, wrong size, bad counts, unknown prompt,
// timeout, unreachable).
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dh/perception/http_segmenter.hpp"
#include "fake_segment_server.hpp"

namespace dh::perception {
namespace {

constexpr int kW = 64, kH = 48;

class HttpSegmenterTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = std::make_unique<testing::FakeSegmentServer>(3.0); }
  static void TearDownTestSuite() { server_.reset(); }

  static cv::Mat image() {
    cv::Mat rgb(kH, kW, CV_8UC3);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(250, static_cast<unsigned char>(4 * x), 10);
    return rgb;
  }
  static std::vector<EntityAppearance> entities() { return {{"bowl", {}, 1}, {"plate", {}, 1}}; }
  /// The rectangle the fake server returns for prompt i.
  static cv::Mat1b expected(int i) {
    cv::Mat1b m = cv::Mat1b::zeros(kH, kW);
    m(cv::Rect(4 + 10 * i, 3, 6, 5)).setTo(255);
    return m;
  }
  static HttpSegmenter segmenter(const std::string& mode, double timeout_s = 2.0) {
    HttpSegmenterConfig c;
    c.url = server_->url(mode);
    c.timeout_s = timeout_s;
    return HttpSegmenter(c);
  }
  /// Expects segment() on `mode` to throw SegmenterError containing every needle.
  static void expect_error(const std::string& mode, const std::vector<std::string>& needles, double timeout_s = 2.0) {
    HttpSegmenter seg = segmenter(mode, timeout_s);
    try {
      seg.segment(image(), entities());
      ADD_FAILURE() << "no SegmenterError for mode " << mode;
    } catch (const SegmenterError& e) {
      for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  }
  static void expect_valid(const std::vector<Mask>& masks) {
    ASSERT_EQ(masks.size(), 2u);
    EXPECT_EQ(masks[0].entity, "bowl");
    EXPECT_EQ(masks[1].entity, "plate");
    EXPECT_DOUBLE_EQ(masks[0].score, 0.9);
    EXPECT_DOUBLE_EQ(masks[1].score, 0.8);
    for (int i = 0; i < 2; ++i) {
      ASSERT_EQ(masks[i].pixels.size(), cv::Size(kW, kH));
      EXPECT_EQ(cv::countNonZero(masks[i].pixels != expected(i)), 0) << "mask " << i;
    }
  }
  static std::unique_ptr<testing::FakeSegmentServer> server_;
};
std::unique_ptr<testing::FakeSegmentServer> HttpSegmenterTest::server_;

TEST_F(HttpSegmenterTest, RleReplyAndTheRequestItSent) {
  expect_valid(segmenter("rle").segment(image(), entities()));
  const auto requests = server_->requests();
  ASSERT_FALSE(requests.empty());
  const nlohmann::json& body = requests.back()["body"];
  EXPECT_EQ(requests.back()["path"], "/rle/segment");
  EXPECT_EQ(body["protocol"], "dh-segment/1");
  EXPECT_EQ(body["prompts"], nlohmann::json::array({"bowl", "plate"}));
  EXPECT_EQ(body["mask_format"], "rle");
  EXPECT_EQ(body["image"]["width"], kW);
  EXPECT_EQ(body["image"]["height"], kH);
  // The PNG the server got decodes to the very image sent, in RGB order.
  const std::string png = base64_decode(body["image"]["data"].get<std::string>());
  cv::Mat bgr = cv::imdecode(cv::Mat(1, static_cast<int>(png.size()), CV_8UC1, const_cast<char*>(png.data())),
                             cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty());
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  cv::Mat diff;
  cv::absdiff(rgb, image(), diff);
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0);
}

TEST_F(HttpSegmenterTest, CompressedRleReply) { expect_valid(segmenter("coco").segment(image(), entities())); }

TEST_F(HttpSegmenterTest, PngReply) { expect_valid(segmenter("png").segment(image(), entities())); }

TEST_F(HttpSegmenterTest, Http500NamesTheStatusAndTheServersReason) {
  expect_error("http500", {"HTTP 500", "model not loaded", "/http500/segment"});
}

TEST_F(HttpSegmenterTest, NonJsonReply) { expect_error("notjson", {"not JSON", "<html>"}); }

TEST_F(HttpSegmenterTest, WrongMaskSize) {
  expect_error("wrongsize", {"mask 0", "size mismatch", "64x49", "the image is 64x48"});
  expect_error("pngsize", {"mask 0", "size mismatch, the PNG is 65x48"});
}

TEST_F(HttpSegmenterTest, CountsNotSummingToTheImage) {
  expect_error("badcounts", {"mask 0", "counts sum to 3071, not width*height = 64*48 = 3072"});
}

TEST_F(HttpSegmenterTest, MaskForAPromptNotAsked) { expect_error("unknown", {"\"teapot\"", "not asked"}); }

TEST_F(HttpSegmenterTest, TimeoutIsReportedInTime) {
  const auto t0 = std::chrono::steady_clock::now();
  expect_error("sleep", {"timed out after 0.3 s"}, 0.3);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(s, 1.5);  // the server sleeps 3 s
}

TEST_F(HttpSegmenterTest, UnreachableServer) {
  HttpSegmenterConfig c;
  c.url = "http://127.0.0.1:" + std::to_string(testing::unused_port()) + "/segment";
  HttpSegmenter seg(c);
  try {
    seg.segment(image(), entities());
    ADD_FAILURE() << "no SegmenterError";
  } catch (const SegmenterError& e) {
    EXPECT_NE(std::string(e.what()).find("unreachable"), std::string::npos) << e.what();
  }
}

TEST(HttpSegmenterConfig, RejectsBadConfiguration) {
  EXPECT_THROW(HttpSegmenter(HttpSegmenterConfig{}), std::invalid_argument);
  HttpSegmenterConfig c;
  c.url = "http://127.0.0.1:1/segment";
  c.mask_format = "polygon";
  EXPECT_THROW(HttpSegmenter{c}, std::invalid_argument);
  c.mask_format = "rle";
  c.timeout_s = 0;
  EXPECT_THROW(HttpSegmenter{c}, std::invalid_argument);
}

TEST(SegmentReply, ParsesWithoutTransportAndRejectsMalformedMasks) {
  const std::vector<std::string> prompts{"bowl"};
  const auto ok = parse_segment_reply(
      R"({"masks": [{"prompt": "bowl", "rle": {"size": [2, 3], "counts": [1, 3, 2]}}]})", 3, 2, prompts);
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok[0].score, 1.0);  // score is optional
  EXPECT_EQ(cv::countNonZero(ok[0].pixels), 3);
  const auto bad = [&](const std::string& body, const std::string& needle) {
    try {
      parse_segment_reply(body, 3, 2, prompts);
      ADD_FAILURE() << "accepted " << body;
    } catch (const SegmenterError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  bad(R"([1, 2])", "not a JSON object");
  bad(R"({"width": 3, "height": 2})", "no \"masks\" array");
  bad(R"({"width": 4, "height": 2, "masks": []})", "size mismatch");
  bad(R"({"masks": [{"rle": {"size": [2, 3], "counts": [6]}}]})", "no \"prompt\"");
  bad(R"({"masks": [{"prompt": "bowl"}]})", "exactly one of \"rle\" and \"png\"");
  bad(R"({"masks": [{"prompt": "bowl", "score": 1.5, "rle": {"size": [2, 3], "counts": [6]}}]})", "outside [0, 1]");
  bad(R"({"masks": [{"prompt": "bowl", "rle": {"size": [2, 3], "counts": [6.5]}}]})", "integers");
  bad(R"({"masks": [{"prompt": "bowl", "png": "###"}]})", "bad base64");
  bad(R"({"error": "no GPU"})", "no GPU");
}

}  // namespace
}  // namespace dh::perception
