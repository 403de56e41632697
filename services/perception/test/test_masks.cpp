// Mask decoding: base64, COCO uncompressed and compressed RLE, base64 PNG; every error names its cause.
#include <gtest/gtest.h>



#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "dh/perception/masks.hpp"

namespace dh::perception {
namespace {

/// Expects `f` to throw MaskDecodeError whose message contains `needle`.
template <class F>
void expect_error(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no MaskDecodeError (expected one mentioning \"" << needle << "\")";
  } catch (const MaskDecodeError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

std::string png_bytes(const cv::Mat& img) {
  std::vector<unsigned char> buf;
  EXPECT_TRUE(cv::imencode(".png", img, buf));
  return std::string(buf.begin(), buf.end());
}

cv::Mat1b random_mask(int w, int h, unsigned seed) {
  std::mt19937 rng(seed);
  cv::Mat1b m(h, w);
  for (auto& v : m) v = (rng() % 3 == 0) ? 255 : 0;
  return m;
}

TEST(Base64, KnownVectorsAndRoundTrip) {
  // RFC 4648 test vectors.
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_decode("Zm9vYg=="), "foob");
  EXPECT_EQ(base64_decode("Zm9vYg"), "foob");            // unpadded
  EXPECT_EQ(base64_decode("Zm9v\nYmFy\r\n"), "foobar");  // line breaks skipped
  std::string all;
  for (int i = 0; i < 256; ++i) all.push_back(static_cast<char>(i));
  EXPECT_EQ(base64_decode(base64_encode(all)), all);
}

TEST(Base64, Errors) {
  expect_error([] { base64_decode("Zm9v!mFy"); }, "'!' at offset 4 is not in the base64 alphabet");
  expect_error([] { base64_decode("Zm9vY"); }, "5 symbols cannot encode whole bytes");
  expect_error([] { base64_decode("Zm=9v"); }, "data after '=' padding");
  expect_error([] { base64_decode("Zm9vYg="); }, "padding");
  expect_error([] { base64_decode("Zg==="); }, "padding");
}

TEST(Rle, ColumnMajorDecode) {
  // 3 wide, 2 high, column-major: pixels (r0,c0) (r1,c0) (r0,c1) (r1,c1) (r0,c2) (r1,c2).
  // counts [1, 3, 2]: background 1, foreground 3, background 2 -> (r1,c0), (r0,c1), (r1,c1).
  const cv::Mat1b m = decode_rle({1, 3, 2}, 3, 2);
  ASSERT_EQ(m.cols, 3);
  ASSERT_EQ(m.rows, 2);
  const cv::Mat1b want = (cv::Mat1b(2, 3) << 0, 255, 0, 255, 255, 0);
  EXPECT_EQ(cv::countNonZero(m != want), 0);
  // A leading 0 means the first pixel is foreground.
  EXPECT_EQ(decode_rle({0, 6}, 3, 2)(0, 0), 255);
  EXPECT_EQ(encode_rle(want), (std::vector<std::int64_t>{1, 3, 2}));
}

TEST(Rle, RoundTripOnARandomMask) {
  const cv::Mat1b m = random_mask(37, 23, 5);
  const auto counts = encode_rle(m);
  EXPECT_EQ(cv::countNonZero(decode_rle(counts, 37, 23) != m), 0);
}

TEST(Rle, Errors) {
  expect_error([] { decode_rle({1, 3, 1}, 3, 2); }, "counts sum to 5, not width*height = 3*2 = 6");
  expect_error([] { decode_rle({4, 4}, 3, 2); }, "counts exceed width*height = 3*2 = 6 (the sum reaches 8 at run 1)");
  expect_error([] { decode_rle({1, -1, 6}, 3, 2); }, "run 1 is negative");
  expect_error([] { decode_rle({6}, 0, 2); }, "not positive");
}

TEST(CocoRleString, HandDerivedVectors) {
  // counts [3, 2, 40, 5]: '3', '2', 40 = 8 | 1<<5 -> 'X' (8 + 32 continuation + 48) then '1',
  // then 5 - counts[1] = 3 -> '3' (differences start at the fourth run, as in pycocotools).
  const cv::Mat1b a = decode_coco_rle_string("32X13", 5, 10);
  EXPECT_EQ(encode_rle(a), (std::vector<std::int64_t>{3, 2, 40, 5}));
  EXPECT_EQ(encode_coco_rle_string(a), "32X13");
  // counts [0, 10, 2, 1]: the last is 1 - 10 = -9 -> 23 with the sign bit (0x10) set -> 'G'.
  const cv::Mat1b b = decode_coco_rle_string("0:2G", 13, 1);
  EXPECT_EQ(encode_rle(b), (std::vector<std::int64_t>{0, 10, 2, 1}));
  EXPECT_EQ(encode_coco_rle_string(b), "0:2G");
}

TEST(CocoRleString, RoundTripAndErrors) {
  const cv::Mat1b m = random_mask(64, 48, 9);
  EXPECT_EQ(cv::countNonZero(decode_coco_rle_string(encode_coco_rle_string(m), 64, 48) != m), 0);
  expect_error([] { decode_coco_rle_string("32X1~", 5, 10); }, "outside '0'..'o'");
  expect_error([] { decode_coco_rle_string("32X", 5, 10); }, "truncated");
  expect_error([] { decode_coco_rle_string("32X13", 5, 9); }, "counts exceed width*height = 5*9 = 45");
  expect_error([] { decode_coco_rle_string("0:2GG", 14, 1); }, "run 4 is negative");  // -9 + 2
}

TEST(PngMask, DecodesGreyColourAndSixteenBit) {
  const cv::Mat1b m = random_mask(40, 30, 3);
  const cv::Mat1b grey = decode_png_base64_mask(base64_encode(png_bytes(m)), 40, 30);
  EXPECT_EQ(cv::countNonZero(grey != m), 0);
  cv::Mat1b ones;
  cv::threshold(m, ones, 0, 1, cv::THRESH_BINARY);  // values 0/1, as many servers write
  EXPECT_EQ(cv::countNonZero(decode_png_base64_mask(base64_encode(png_bytes(ones)), 40, 30) != m), 0);
  cv::Mat sixteen;
  ones.convertTo(sixteen, CV_16U);  // 16-bit with value 1: must not round down to 0
  EXPECT_EQ(cv::countNonZero(decode_png_base64_mask(base64_encode(png_bytes(sixteen)), 40, 30) != m), 0);
  cv::Mat colour;
  cv::Mat channels[] = {cv::Mat1b::zeros(30, 40), m, cv::Mat1b::zeros(30, 40)};
  cv::merge(channels, 3, colour);
  EXPECT_EQ(cv::countNonZero(decode_png_base64_mask(base64_encode(png_bytes(colour)), 40, 30) != m), 0);
}

TEST(PngMask, Errors) {
  const cv::Mat1b m = random_mask(40, 30, 3);
  const std::string b64 = base64_encode(png_bytes(m));
  expect_error([&] { decode_png_base64_mask(b64, 41, 30); }, "size mismatch, the PNG is 40x30, the image is 41x30");
  expect_error([&] { decode_png_base64_mask("iVBO#", 40, 30); }, "bad base64");
  expect_error([&] { decode_png_base64_mask(base64_encode("GIF89a not a png"), 40, 30); }, "PNG signature");
  const std::string truncated = png_bytes(m).substr(0, 40);
  expect_error([&] { decode_png_base64_mask(base64_encode(truncated), 40, 30); }, "does not decode");
}

}  // namespace
}  // namespace dh::perception
