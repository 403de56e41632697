#include "dh/frames/recording.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "dh/common/config.hpp"

namespace dh::frames {

namespace fs = std::filesystem;

namespace {

std::string describe(const cv::Mat& m) {
  const int depth = m.depth();
  const char* bits = depth == CV_8U    ? "8-bit"
                     : depth == CV_16U ? "16-bit"
                     : depth == CV_8S  ? "8-bit signed"
                     : depth == CV_16S ? "16-bit signed"
                     : depth == CV_32F ? "32-bit float"
                                       : "other-depth";
  return std::string(bits) + " " + std::to_string(m.channels()) + "-channel " + std::to_string(m.cols) + "x" +
         std::to_string(m.rows);
}

/// PNGs in `dir` by stem.
std::map<std::string, fs::path> pngs(const fs::path& dir) {
  std::map<std::string, fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png") out[e.path().stem().string()] = e.path();
  }
  return out;
}

double positive(const ConfigNode& n, const std::string& key) {
  const double v = n.get<double>(key);
  if (!(v > 0) || !std::isfinite(v)) n.fail(key, "must be a positive number, not " + std::to_string(v));
  return v;
}

double either(const ConfigNode& n, const std::string& key, const std::string& alias) {
  if (n.has(key) && n.has(alias)) n.fail(key, "given twice (as '" + key + "' and '" + alias + "'); keep one");
  const std::string k = n.has(alias) ? alias : key;
  const double v = n.get<double>(k);
  if (!std::isfinite(v)) n.fail(k, "must be a finite number");
  return v;
}

}  // namespace

CameraFile read_camera_file(const fs::path& file, bool intrinsics_required) {
  if (!fs::exists(file))
    throw FramesError(file.string() + ": missing (" +
                      (intrinsics_required ? "a recording needs intrinsics.yaml beside color/ and depth/"
                                           : "a camera's file: its name, pose and, optionally, intrinsics") +
                      ")");
  try {
    const ConfigNode n = ConfigNode::load_file(file);
    if (!n.raw().IsMap())
      throw FramesError(file.string() + ": expected a YAML map of intrinsics (fx, fy, cx, cy, ...)");
    CameraFile c;
    int given = 0;
    for (const char* key : {"width", "height", "fx", "fy"}) given += n.has(key);
    given += n.has("cx") || n.has("ppx");
    given += n.has("cy") || n.has("ppy");
    if (intrinsics_required || given > 0) {
      const int width = n.get<int>("width"), height = n.get<int>("height");
      if (width < 1) n.fail("width", "must be a positive integer");
      if (height < 1) n.fail("height", "must be a positive integer");
      c.K.width = width;
      c.K.height = height;
      c.K.fx = positive(n, "fx");
      c.K.fy = positive(n, "fy");
      c.K.cx = either(n, "cx", "ppx");
      c.K.cy = either(n, "cy", "ppy");
      c.has_intrinsics = true;
    }
    if (n.has("depth_scale")) c.depth_scale = positive(n, "depth_scale");
    if (n.has("camera")) {
      c.camera = n.get<std::string>("camera");
      if (c.camera.empty()) n.fail("camera", "must not be empty");
    }
    if (n.has("pose")) {
      const ConfigNode p = n.child("pose");
      const auto pos = p.get<std::vector<double>>("position");
      if (pos.size() != 3) p.fail("position", "expected 3 numbers [x, y, z] (m)");
      const auto q = p.get<std::vector<double>>("orientation");
      if (q.size() != 4) p.fail("orientation", "expected 4 numbers [w, x, y, z] (a unit quaternion)");
      const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(std::abs(norm - 1) <= 0.01))
        p.fail("orientation", "is not a unit quaternion [w, x, y, z] (norm " + std::to_string(norm) + ")");
      for (int i = 0; i < 3; ++i) c.position[i] = pos[i];
      for (int i = 0; i < 4; ++i) c.orientation[i] = q[i] / norm;
      c.has_pose = true;
    }
    return c;
  } catch (const ConfigError& e) {
    throw FramesError(e.what());
  }
}

Recording open_recording(const fs::path& folder) {
  if (!fs::is_directory(folder))
    throw FramesError(folder.string() + ": " + (fs::exists(folder) ? "not a folder" : "no such folder") +
                      " (a recording is a folder with intrinsics.yaml, color/ and depth/)");
  Recording rec;
  rec.folder = folder;
  static_cast<CameraFile&>(rec) = read_camera_file(folder / kIntrinsicsFile, true);
  const fs::path color_dir = folder / kColorDir, depth_dir = folder / kDepthDir;
  for (const auto& d : {color_dir, depth_dir})
    if (!fs::is_directory(d))
      throw FramesError(
          d.string() + ": missing (colour PNGs go in color/, 16-bit depth PNGs of the same names in depth/)");
  const auto colors = pngs(color_dir), depths = pngs(depth_dir);
  for (const auto& [stem, file] : colors)
    if (!depths.count(stem))
      throw FramesError(file.string() + ": no depth image for it (" + (depth_dir / (stem + ".png")).string() +
                        " is missing)");
  for (const auto& [stem, file] : depths)
    if (!colors.count(stem))
      throw FramesError(file.string() + ": no colour image for it (" +
                        (color_dir / (stem + ".png")).string() + " is missing)");
  if (colors.empty()) throw FramesError(color_dir.string() + ": no PNG frames");
  for (const auto& [stem, file] : colors) rec.frames.push_back({stem, file, depths.at(stem)});
  return rec;
}

std::uint16_t raw_depth_to_mm(std::uint16_t raw, double depth_scale) {
  if (raw == 0) return 0;
  const double mm = std::round(raw * depth_scale * 1000.0);
  return mm >= 1 && mm <= 65535 ? static_cast<std::uint16_t>(mm) : 0;
}

Frame read_frame(const Recording& rec, std::size_t index) {
  if (index >= rec.frames.size())
    throw std::out_of_range("frame " + std::to_string(index) + " of a recording with " +
                            std::to_string(rec.frames.size()) + " frames");
  const auto& entry = rec.frames[index];
  const auto size_check = [&](const cv::Mat& m, const fs::path& file) {
    if (m.cols != rec.K.width || m.rows != rec.K.height)
      throw FramesError(file.string() + ": the image is " + std::to_string(m.cols) + "x" +
                        std::to_string(m.rows) + " but " + (rec.folder / kIntrinsicsFile).string() +
                        " says " + std::to_string(rec.K.width) + "x" + std::to_string(rec.K.height));
  };
  Frame f;
  f.index = index;
  f.stem = entry.stem;
  f.width = rec.K.width;
  f.height = rec.K.height;

  cv::Mat color = cv::imread(entry.color.string(), cv::IMREAD_UNCHANGED);
  if (color.empty())
    throw FramesError(entry.color.string() + ": cannot be decoded as a PNG image (unreadable or corrupt)");
  if (color.depth() != CV_8U)
    throw FramesError(entry.color.string() + ": colour must be 8 bits per channel; the image is " +
                      describe(color));
  size_check(color, entry.color);
  cv::Mat rgb;
  switch (color.channels()) {
    case 1:
      cv::cvtColor(color, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      cv::cvtColor(color, rgb, cv::COLOR_BGR2RGB);
      break;  // OpenCV decodes into BGR order
    case 4:
      cv::cvtColor(color, rgb, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw FramesError(entry.color.string() + ": expected a grey, RGB or RGBA image; the image is " +
                        describe(color));
  }
  f.rgb.assign(rgb.data, rgb.data + rgb.total() * 3);  // cvtColor's output is continuous

  cv::Mat depth = cv::imread(entry.depth.string(), cv::IMREAD_UNCHANGED);
  if (depth.empty())
    throw FramesError(entry.depth.string() + ": cannot be decoded as a PNG image (unreadable or corrupt)");
  if (depth.type() != CV_16UC1)
    throw FramesError(entry.depth.string() + ": depth must be a 16-bit single-channel PNG; the image is " +
                      describe(depth));
  size_check(depth, entry.depth);
  f.depth_mm.resize(depth.total());
  for (int r = 0; r < depth.rows; ++r) {
    const auto* src = depth.ptr<std::uint16_t>(r);
    std::uint16_t* dst = f.depth_mm.data() + static_cast<std::size_t>(r) * depth.cols;
    if (rec.depth_scale == 0.001)
      std::copy(src, src + depth.cols, dst);
    else
      for (int c = 0; c < depth.cols; ++c) dst[c] = raw_depth_to_mm(src[c], rec.depth_scale);
  }
  return f;
}

std::vector<std::uint8_t> depth_le_bytes(const std::vector<std::uint16_t>& depth_mm) {
  std::vector<std::uint8_t> out(2 * depth_mm.size());
  for (std::size_t i = 0; i < depth_mm.size(); ++i) {
    out[2 * i] = static_cast<std::uint8_t>(depth_mm[i] & 0xFF);
    out[2 * i + 1] = static_cast<std::uint8_t>(depth_mm[i] >> 8);
  }
  return out;
}

}  // namespace dh::frames
