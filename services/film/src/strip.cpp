#include "strip.hpp"

#include <algorithm>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

namespace dh::film {
namespace {

constexpr int kPerRow = 5;
constexpr int kMargin = 6;
constexpr int kLine = 15;  // caption line height at kScale
constexpr double kScale = 0.42;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// Our images are RGB; OpenCV writes BGR.
cv::Mat bgr(const sim::Image& im) {
  cv::Mat rgb(im.height, im.width, CV_8UC3, const_cast<std::uint8_t*>(im.rgb.data()));
  cv::Mat out;
  cv::cvtColor(rgb, out, cv::COLOR_RGB2BGR);
  return out;
}

// The text as it fits `width` pixels, cut with "..." when it does not.
std::string fitted(std::string text, int width, double scale) {
  const auto w = [&](const std::string& s) { return cv::getTextSize(s, kFont, scale, 1, nullptr).width; };
  if (w(text) <= width) return text;
  while (!text.empty() && w(text + "...") > width) text.pop_back();
  return text + "...";
}

}  // namespace

void write_strip(const std::filesystem::path& png, const std::vector<std::string>& title,
                 const std::vector<sim::Image>& frames, const std::vector<std::vector<std::string>>& captions) {
  if (frames.empty()) throw std::invalid_argument("a strip needs at least one frame");
  const int fw = frames.front().width, fh = frames.front().height;
  const int lines = static_cast<int>(std::max_element(captions.begin(), captions.end(), [](auto& a, auto& b) {
                                       return a.size() < b.size();
                                     })->size());
  const int cols = std::min<int>(kPerRow, static_cast<int>(frames.size()));
  const int rows = (static_cast<int>(frames.size()) + kPerRow - 1) / kPerRow;
  const int cell_w = fw + kMargin, cell_h = fh + lines * kLine + 2 * kMargin;
  const int title_h = static_cast<int>(title.size()) * (kLine + 3) + kMargin;
  cv::Mat strip(title_h + rows * cell_h + kMargin, cols * cell_w + kMargin, CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t i = 0; i < title.size(); ++i)
    cv::putText(strip, fitted(title[i], strip.cols - 2 * kMargin, kScale * 1.15),
                {kMargin, kMargin + static_cast<int>(i + 1) * (kLine + 3) - 4}, kFont, kScale * 1.15,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const int x = kMargin + static_cast<int>(i % kPerRow) * cell_w;
    const int y = title_h + static_cast<int>(i / kPerRow) * cell_h;
    bgr(frames[i]).copyTo(strip(cv::Rect(x, y, fw, fh)));
    for (std::size_t l = 0; l < captions[i].size(); ++l)
      cv::putText(strip, fitted(captions[i][l], fw, kScale), {x, y + fh + kMargin + static_cast<int>(l + 1) * kLine - 4},
                  kFont, kScale, l == 0 ? cv::Scalar(0, 0, 0) : cv::Scalar(60, 60, 60), 1, cv::LINE_AA);
  }
  bool written = false;
  try {
    written = cv::imwrite(png.string(), strip);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(png.string() + ": the strip could not be written: " + e.what());
  }
  if (!written) throw std::runtime_error(png.string() + ": the strip could not be written (is it a .png in a folder that exists?)");
}

struct VideoOut::Writer {
  cv::VideoWriter video;
  cv::Size size;
};

VideoOut::VideoOut(const std::filesystem::path& file, int width, int height) : writer_(std::make_unique<Writer>()) {
  const std::string ext = file.extension().string();
  const int fourcc = ext == ".webm" ? cv::VideoWriter::fourcc('V', 'P', '8', '0')
                     : ext == ".mp4" ? cv::VideoWriter::fourcc('m', 'p', '4', 'v')
                                     : 0;
  if (!fourcc) throw std::invalid_argument(file.string() + ": a video is .webm (VP8) or .mp4 (MPEG-4)");
  writer_->size = {width, height};
  writer_->video.open(file.string(), cv::CAP_FFMPEG, fourcc, 20.0, writer_->size);
  if (!writer_->video.isOpened())
    throw std::runtime_error(file.string() + ": no video encoder took it (OpenCV's FFmpeg backend with " +
                             (ext == ".webm" ? "VP8" : "MPEG-4") + "; does its folder exist?)");
}

VideoOut::~VideoOut() = default;

void VideoOut::write(const sim::Image& frame) { writer_->video.write(bgr(frame)); }

}  // namespace dh::film
