#include "dh/perception/masks.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace dh::perception {

namespace {

constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::array<int, 256> decode_table() {
  std::array<int, 256> t{};
  t.fill(-1);
  for (int i = 0; i < 64; ++i) t[static_cast<unsigned char>(kAlphabet[i])] = i;
  return t;
}

bool is_space(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

void check_size(int width, int height, const char* what) {
  if (width <= 0 || height <= 0)
    throw MaskDecodeError(std::string(what) + ": mask size " + std::to_string(width) + "x" +
                          std::to_string(height) + " is not positive");
}

/// Column-major runs to a row-major mask: fill the transposed image linearly, then transpose.
cv::Mat1b runs_to_mask(const std::vector<std::int64_t>& counts, int width, int height, const char* what) {
  check_size(width, height, what);
  const std::int64_t total = static_cast<std::int64_t>(width) * height;
  const std::string area = "width*height = " + std::to_string(width) + "*" + std::to_string(height) + " = " +
                           std::to_string(total);
  std::int64_t sum = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    if (counts[i] < 0)
      throw MaskDecodeError(std::string(what) + ": run " + std::to_string(i) + " is negative (" +
                            std::to_string(counts[i]) + ")");
    sum += counts[i];
    if (sum > total)
      throw MaskDecodeError(std::string(what) + ": the counts exceed " + area + " (the sum reaches " +
                            std::to_string(sum) + " at run " + std::to_string(i) + ")");
  }
  if (sum != total)
    throw MaskDecodeError(std::string(what) + ": the counts sum to " + std::to_string(sum) + ", not " + area);
  cv::Mat1b transposed(width, height, static_cast<unsigned char>(0));  // rows = columns of the mask
  unsigned char* p = transposed.ptr<unsigned char>(0);
  std::int64_t at = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    if (i % 2 == 1 && counts[i] > 0) std::memset(p + at, 255, static_cast<std::size_t>(counts[i]));
    at += counts[i];
  }
  cv::Mat1b out;
  cv::transpose(transposed, out);
  return out;
}

std::vector<std::int64_t> mask_to_runs(const cv::Mat1b& mask) {
  std::vector<std::int64_t> counts;
  if (mask.empty()) return counts;
  cv::Mat1b transposed;
  cv::transpose(mask, transposed);  // continuous: column-major order of the mask
  const unsigned char* p = transposed.ptr<unsigned char>(0);
  const std::size_t n = transposed.total();
  bool fg = false;
  std::int64_t run = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool v = p[i] != 0;
    if (v != fg) {
      counts.push_back(run);
      run = 0;
      fg = v;
    }
    ++run;
  }
  counts.push_back(run);
  return counts;
}

}  // namespace

std::string base64_decode(std::string_view text) {
  static const std::array<int, 256> table = decode_table();
  std::string out;
  out.reserve(text.size() / 4 * 3 + 3);
  std::uint32_t acc = 0;
  int bits = 0;
  std::size_t symbols = 0, padding = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (is_space(c)) continue;
    if (c == '=') {
      ++padding;
      continue;
    }
    const int v = table[static_cast<unsigned char>(c)];
    if (v < 0)
      throw MaskDecodeError("bad base64: character " +
                            (c >= 32 && c < 127 ? "'" + std::string(1, c) + "'"
                                                : "code " + std::to_string(static_cast<unsigned char>(c))) +
                            " at offset " + std::to_string(i) + " is not in the base64 alphabet");
    if (padding > 0) throw MaskDecodeError("bad base64: data after '=' padding at offset " + std::to_string(i));
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    ++symbols;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xFF));
    }
  }
  if (symbols % 4 == 1)
    throw MaskDecodeError("bad base64: " + std::to_string(symbols) + " symbols cannot encode whole bytes");
  if (padding > 2 || (padding > 0 && (symbols + padding) % 4 != 0))
    throw MaskDecodeError("bad base64: " + std::to_string(padding) + " padding characters after " +
                          std::to_string(symbols) + " symbols");
  return out;
}

std::string base64_encode(std::string_view bytes) {
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (static_cast<unsigned char>(bytes[i]) << 16) |
                            (static_cast<unsigned char>(bytes[i + 1]) << 8) | static_cast<unsigned char>(bytes[i + 2]);
    out.push_back(kAlphabet[(v >> 18) & 63]);
    out.push_back(kAlphabet[(v >> 12) & 63]);
    out.push_back(kAlphabet[(v >> 6) & 63]);
    out.push_back(kAlphabet[v & 63]);
  }
  const std::size_t rest = bytes.size() - i;
  if (rest > 0) {
    std::uint32_t v = static_cast<unsigned char>(bytes[i]) << 16;
    if (rest == 2) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out.push_back(kAlphabet[(v >> 18) & 63]);
    out.push_back(kAlphabet[(v >> 12) & 63]);
    out.push_back(rest == 2 ? kAlphabet[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

cv::Mat1b decode_rle(const std::vector<std::int64_t>& counts, int width, int height) {
  return runs_to_mask(counts, width, height, "RLE");
}

std::vector<std::int64_t> encode_rle(const cv::Mat1b& mask) { return mask_to_runs(mask); }

cv::Mat1b decode_coco_rle_string(std::string_view s, int width, int height) {
  check_size(width, height, "COCO RLE string");
  std::vector<std::int64_t> counts;
  std::size_t p = 0;
  while (p < s.size()) {
    std::int64_t x = 0;
    int k = 0;
    bool more = true;
    while (more) {
      if (p >= s.size())
        throw MaskDecodeError("COCO RLE string: truncated value at the end (offset " + std::to_string(p) + ")");
      const int c = static_cast<unsigned char>(s[p]) - 48;
      if (c < 0 || c > 63)
        throw MaskDecodeError("COCO RLE string: character '" + std::string(1, s[p]) + "' at offset " +
                              std::to_string(p) + " is outside '0'..'o'");
      if (k >= 12) throw MaskDecodeError("COCO RLE string: value too long at offset " + std::to_string(p));
      x |= static_cast<std::int64_t>(c & 0x1f) << (5 * k);
      more = (c & 0x20) != 0;
      ++p;
      ++k;
      if (!more && (c & 0x10)) x |= -(static_cast<std::int64_t>(1) << (5 * k));  // sign-extend
    }
    if (counts.size() > 2) x += counts[counts.size() - 2];
    counts.push_back(x);
  }
  return runs_to_mask(counts, width, height, "COCO RLE string");
}

std::string encode_coco_rle_string(const cv::Mat1b& mask) {
  const std::vector<std::int64_t> counts = mask_to_runs(mask);
  std::string s;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    std::int64_t x = counts[i];
    if (i > 2) x -= counts[i - 2];
    bool more = true;
    while (more) {
      int c = static_cast<int>(x & 0x1f);
      x >>= 5;  // arithmetic shift: negative differences end at -1
      more = (c & 0x10) ? x != -1 : x != 0;
      if (more) c |= 0x20;
      s.push_back(static_cast<char>(c + 48));
    }
  }
  return s;
}

cv::Mat1b decode_png_base64_mask(std::string_view base64_png, int width, int height) {
  check_size(width, height, "PNG mask");
  const std::string bytes = base64_decode(base64_png);
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kSignature, 8) != 0)
    throw MaskDecodeError("PNG mask: the decoded " + std::to_string(bytes.size()) +
                          " bytes do not start with the PNG signature");
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  const cv::Mat img = cv::imdecode(raw, cv::IMREAD_UNCHANGED);  // keeps 16-bit values and channels
  if (img.empty()) throw MaskDecodeError("PNG mask: the PNG data does not decode (corrupt or truncated)");
  if (img.cols != width || img.rows != height)
    throw MaskDecodeError("PNG mask: size mismatch, the PNG is " + std::to_string(img.cols) + "x" +
                          std::to_string(img.rows) + ", the image is " + std::to_string(width) + "x" +
                          std::to_string(height));
  cv::Mat1b out;
  if (img.channels() == 1) {
    cv::compare(img, 0, out, cv::CMP_NE);  // 255 where nonzero
  } else {  // colour: in the mask where any colour channel is nonzero (alpha ignored)
    std::vector<cv::Mat> channels;
    cv::split(img, channels);
    out = cv::Mat1b::zeros(img.rows, img.cols);
    for (int c = 0; c < std::min(3, img.channels()); ++c) {
      cv::Mat1b nz;
      cv::compare(channels[c], 0, nz, cv::CMP_NE);
      out |= nz;
    }
  }
  return out;
}

}  // namespace dh::perception
