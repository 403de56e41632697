#include "dh/perception/colour_segmenter.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace dh::perception {

namespace {

constexpr int kShadeLevels = 64;
constexpr unsigned char kMatch = 1, kLit = 2;  // a colour LUT's bits
constexpr int kBins = 64;  // per channel: 6 bits, 4 values per bin
constexpr int kLutSize = kBins * kBins * kBins;
constexpr float kL8ToL = 100.0f / 255.0f;  // OpenCV's 8-bit Lab stores L* * 255 / 100, a* + 128, b* + 128

int bin_index(const unsigned char* rgb) { return ((rgb[0] >> 2) << 12) | ((rgb[1] >> 2) << 6) | (rgb[2] >> 2); }

/// 8-bit Lab of every bin's centre colour (values 4q + 2 = 2 ... 254), in bin_index order.
const cv::Mat& bin_centre_lab() {
  static const cv::Mat lab = [] {
    cv::Mat rgb(kBins * kBins, kBins, CV_8UC3), out;
    for (int i = 0; i < kLutSize; ++i) {
      cv::Vec3b& v = rgb.at<cv::Vec3b>(i / kBins, i % kBins);
      v[0] = static_cast<unsigned char>(((i >> 12) & 63) * 4 + 2);
      v[1] = static_cast<unsigned char>(((i >> 6) & 63) * 4 + 2);
      v[2] = static_cast<unsigned char>((i & 63) * 4 + 2);
    }
    cv::cvtColor(rgb, out, cv::COLOR_RGB2Lab);
    return out;
  }();
  return lab;
}

/// Lab of `colour` scaled by kShadeLevels shading factors evenly spaced over [kmin, kmax].
cv::Mat shaded_lab(const cv::Vec3b& colour, float kmin, float kmax) {
  cv::Mat shaded(1, kShadeLevels, CV_8UC3), lab;
  for (int i = 0; i < kShadeLevels; ++i) {
    const float k = kmin + (kmax - kmin) * static_cast<float>(i) / (kShadeLevels - 1);
    for (int ch = 0; ch < 3; ++ch)
      shaded.at<cv::Vec3b>(0, i)[ch] = cv::saturate_cast<unsigned char>(k * static_cast<float>(colour[ch]));
  }
  cv::cvtColor(shaded, lab, cv::COLOR_RGB2Lab);
  return lab;
}

double chroma(const cv::Vec3b& lab8) { return std::hypot(lab8[1] - 128.0, lab8[2] - 128.0); }

/// The darkest shade at which `colour` still matches: achromatic_min_shade for an achromatic colour; for
/// a chromatic one the shade where darkening brings its chroma down to achromatic_chroma, since darker it
/// is as grey as the achromatic ones (cream (217,217,179) from about 0.53, a saturated red from min_shade).
float lowest_shade(const cv::Vec3b& colour, const ColourSegmenterParams& p) {
  const auto kmin = static_cast<float>(p.min_shade), kmax = static_cast<float>(p.max_shade);
  if (chroma(shaded_lab(colour, 1.0f, 1.0f).at<cv::Vec3b>(0, 0)) < p.achromatic_chroma)
    return std::min(kmax, std::max(kmin, static_cast<float>(p.achromatic_min_shade)));
  const cv::Mat lab = shaded_lab(colour, kmin, kmax);
  int first = 0;
  while (first + 1 < kShadeLevels && chroma(lab.at<cv::Vec3b>(0, first)) < p.achromatic_chroma) ++first;
  return kmin + (kmax - kmin) * static_cast<float>(first) / (kShadeLevels - 1);
}

/// For every bin: does its centre colour match `colour` under some allowed shading factor (kMatch), and
/// at a lit one (kLit)?
std::vector<unsigned char> colour_lut(const cv::Vec3b& colour, const ColourSegmenterParams& p) {
  const float cr = colour[0], cg = colour[1], cb = colour[2];
  const float cc = cr * cr + cg * cg + cb * cb;
  const float kmin = lowest_shade(colour, p), kmax = static_cast<float>(p.max_shade);
  // Lab of the material colour at kShadeLevels shading factors in [kmin, kmax] (black: itself).
  const cv::Mat shaded = cc < 1 ? shaded_lab(colour, 1.0f, 1.0f) : shaded_lab(colour, kmin, kmax);
  std::array<float, kShadeLevels> tl{}, ta{}, tb{};
  for (int i = 0; i < kShadeLevels; ++i) {
    const cv::Vec3b v = shaded.at<cv::Vec3b>(0, i);
    tl[i] = v[0] * kL8ToL;
    ta[i] = v[1];
    tb[i] = v[2];
  }
  const float tol2 = static_cast<float>(p.tolerance * p.tolerance);
  const float inv_cc = cc < 1 ? 0.0f : 1.0f / cc;
  const float level_scale = kmax > kmin ? (kShadeLevels - 1) / (kmax - kmin) : 0.0f;
  const cv::Mat& lab = bin_centre_lab();  // continuous, in bin_index order
  const unsigned char* lab_px = lab.ptr<unsigned char>(0);
  std::vector<unsigned char> lut(kLutSize);
  for (int i = 0; i < kLutSize; ++i) {
    const float r = static_cast<float>(((i >> 12) & 63) * 4 + 2), g = static_cast<float>(((i >> 6) & 63) * 4 + 2),
                b = static_cast<float>((i & 63) * 4 + 2);
    int level = 0;
    bool lit = true;  // black has no shades
    if (inv_cc > 0) {
      const float k = std::clamp((r * cr + g * cg + b * cb) * inv_cc, kmin, kmax);
      level = static_cast<int>((k - kmin) * level_scale + 0.5f);
      lit = k >= static_cast<float>(p.lit_min_shade);
    }
    const unsigned char* l = lab_px + 3 * static_cast<std::ptrdiff_t>(i);
    const float dl = l[0] * kL8ToL - tl[level];
    const float da = static_cast<float>(l[1]) - ta[level];
    const float db = static_cast<float>(l[2]) - tb[level];
    const bool match = dl * dl + da * da + db * db <= tol2;
    lut[static_cast<std::size_t>(i)] = match ? static_cast<unsigned char>(kMatch | (lit ? kLit : 0)) : 0;
  }
  return lut;
}

std::uint32_t colour_key(const cv::Vec3b& c) {
  return (static_cast<std::uint32_t>(c[0]) << 16) | (static_cast<std::uint32_t>(c[1]) << 8) | c[2];
}

}  // namespace

ColourSegmenter::ColourSegmenter(ColourSegmenterParams params) : params_(params) {
  const ColourSegmenterParams& p = params_;
  if (!(p.tolerance > 0) || !(p.min_shade > 0) || !(p.max_shade >= p.min_shade))
    throw std::invalid_argument("colour segmenter: tolerance and shade range must be positive, min <= max");
}

const std::vector<unsigned char>& ColourSegmenter::lut_of(const cv::Vec3b& colour) {
  const std::uint32_t key = colour_key(colour);
  auto it = luts_.find(key);
  if (it == luts_.end()) it = luts_.emplace(key, colour_lut(colour, params_)).first;
  return it->second;
}

void ColourSegmenter::prepare(const std::vector<EntityAppearance>& entities) {
  for (const EntityAppearance& e : entities)
    for (const cv::Vec3b& c : e.rgb) lut_of(c);
}

std::vector<Mask> ColourSegmenter::segment(const cv::Mat& rgb, const std::vector<EntityAppearance>& entities) {
  if (rgb.empty() || rgb.type() != CV_8UC3)
    throw std::invalid_argument("colour segmenter: the image must be a non-empty CV_8UC3 (RGB)");
  const ColourSegmenterParams& p = params_;
  for (const EntityAppearance& e : entities)
    if (e.rgb.size() > kMaxColours)
      throw std::invalid_argument("colour segmenter: entity '" + e.entity + "' has " + std::to_string(e.rgb.size()) +
                                  " colours, at most " + std::to_string(kMaxColours) + " are supported");
  // Each pixel's colour bin, once per frame.
  cv::Mat1i bins(rgb.rows, rgb.cols);
  for (int y = 0; y < rgb.rows; ++y) {
    const unsigned char* px = rgb.ptr<unsigned char>(y);
    int* b = bins.ptr<int>(y);
    for (int x = 0; x < rgb.cols; ++x, px += 3) b[x] = bin_index(px);
  }
  const cv::Rect frame_rect(0, 0, rgb.cols, rgb.rows);
  const int pad = std::max(p.close_px, 1);

  std::vector<Mask> out;
  for (const EntityAppearance& entity : entities) {
    if (entity.rgb.empty()) continue;
    const std::size_t ncol = entity.rgb.size();
    std::vector<const std::vector<unsigned char>*> luts;
    for (const cv::Vec3b& c : entity.rgb) luts.push_back(&lut_of(c));
    // Per pixel: a bit per matching colour of the entity, and whether one matches lit.
    cv::Mat1b colours(rgb.rows, rgb.cols), any(rgb.rows, rgb.cols), lit(rgb.rows, rgb.cols);
    for (int y = 0; y < rgb.rows; ++y) {
      const int* b = bins.ptr<int>(y);
      unsigned char* c = colours.ptr<unsigned char>(y);
      unsigned char* a = any.ptr<unsigned char>(y);
      unsigned char* li = lit.ptr<unsigned char>(y);
      for (int x = 0; x < rgb.cols; ++x) {
        unsigned bits = 0, lit_bits = 0;
        for (std::size_t j = 0; j < ncol; ++j) {
          const unsigned v = (*luts[j])[static_cast<std::size_t>(b[x])];
          bits |= (v & kMatch) << j;
          lit_bits |= v & kLit;
        }
        c[x] = static_cast<unsigned char>(bits);
        a[x] = bits ? 255 : 0;
        li[x] = lit_bits ? 1 : 0;
      }
    }
    cv::Mat1b opened = any;
    if (p.open_px > 1)
      cv::morphologyEx(any, opened, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, {p.open_px, p.open_px}));
    // Close and label inside the bounding box of what survived the opening (padded for the closing).
    const cv::Rect box = cv::boundingRect(opened);
    if (box.area() == 0) continue;
    const cv::Rect roi = cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad) & frame_rect;
    cv::Mat1b clean = opened(roi).clone();
    if (p.close_px > 1)
      cv::morphologyEx(clean, clean, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {p.close_px, p.close_px}));
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(clean, labels, stats, centroids, 8, CV_32S);
    if (n <= 1) continue;
    // Per component: pixels of each colour and of any colour (as matched, before the morphology).
    std::vector<std::vector<int>> colour_px(ncol, std::vector<int>(static_cast<std::size_t>(n), 0));
    std::vector<int> any_px(static_cast<std::size_t>(n), 0), lit_px(static_cast<std::size_t>(n), 0);
    for (int y = 0; y < roi.height; ++y) {
      const int* l = labels.ptr<int>(y);
      const unsigned char* c = colours.ptr<unsigned char>(roi.y + y) + roi.x;
      const unsigned char* lt = lit.ptr<unsigned char>(roi.y + y) + roi.x;
      for (int x = 0; x < roi.width; ++x) {
        if (l[x] == 0 || c[x] == 0) continue;
        const auto li = static_cast<std::size_t>(l[x]);
        ++any_px[li];
        lit_px[li] += lt[x];
        for (std::size_t j = 0; j < ncol; ++j)
          if (c[x] & (1u << j)) ++colour_px[j][li];
      }
    }
    struct Candidate {
      int label, area;
      double score;
    };
    std::vector<Candidate> candidates;
    for (int l = 1; l < n; ++l) {
      const int area = stats.at<int>(l, cv::CC_STAT_AREA);
      if (area < entity.min_area_px || (entity.max_area_px > 0 && area > entity.max_area_px)) continue;
      const auto li = static_cast<std::size_t>(l);
      if (colour_px[0][li] < p.main_colour_min_fraction * area || lit_px[li] < p.lit_min_fraction * area) continue;
      std::size_t present = 0;
      for (std::size_t j = 0; j < ncol; ++j)
        if (colour_px[j][li] > 0 && colour_px[j][li] >= p.part_min_fraction * area) ++present;
      const double score = static_cast<double>(present) / static_cast<double>(ncol) *
                           std::min(1.0, static_cast<double>(any_px[li]) / area);
      candidates.push_back({l, area, score});
    }
    // Labels are numbered in raster order of their first pixel: a stable sort keeps that for ties.
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.area > b.area; });
    for (const Candidate& c : candidates) {
      Mask m;
      m.entity = entity.entity;
      m.score = c.score;
      m.pixels = cv::Mat1b::zeros(rgb.rows, rgb.cols);
      cv::Mat1b part = m.pixels(roi);
      cv::compare(labels, c.label, part, cv::CMP_EQ);
      out.push_back(std::move(m));
    }
  }
  return out;
}

}  // namespace dh::perception
