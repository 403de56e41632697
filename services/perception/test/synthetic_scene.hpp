// A small ray caster for constructed RGB-D frames: a table plane and boxes and vertical cylinders at known
// poses, seen by a pinhole camera; Lambert shading and optional noise. Exact depths and per-pixel object
// ids come with the frame, so tests can compare against analytic truth. Used by the perception tests and
// bench/bench_perception.cpp.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "dh/perception/frame.hpp"

namespace dh::perception::synth {

struct Box {
  Eigen::Vector3d centre;
  double yaw = 0;  ///< about world z
  Eigen::Vector3d size;
  cv::Vec3b rgb;
};

struct Cylinder {  ///< vertical, standing on its base
  Eigen::Vector3d base_centre;
  double radius = 0, height = 0;
  cv::Vec3b rgb;
};

struct Scene {
  Intrinsics K{615.0, 615.0, 319.5, 239.5, 640, 480};  ///< a RealSense D435 colour-aligned depth at 640x480
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  bool table = true;
  double table_z = 0;
  cv::Vec3b table_rgb{150, 150, 150};
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  Eigen::Vector3d light = Eigen::Vector3d(0.3, -0.4, 1.0).normalized();  ///< towards the light
  double ambient = 0.55;                                                ///< shade = ambient + (1-ambient) n.l
};

struct Noise {
  double colour_sigma = 0;      ///< per channel, 8-bit units
  double salt_pepper = 0;       ///< share of pixels set to random colours
  double depth_sigma_mm = 0;
  double depth_dropout = 0;     ///< share of valid depth pixels set to 0
  unsigned seed = 1;
};

struct Rendered {
  RgbdFrame frame;
  cv::Mat1i ids;           ///< -1 nothing, 0 table, 1.. boxes in order, then cylinders
  cv::Mat1d exact_depth_m; ///< z of the hit before quantisation and noise, 0 where nothing
};

/// The camera at `eye` looking at `target`, OpenCV axes (x right, y down, z forward), world z up.
inline Eigen::Isometry3d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

inline Eigen::Matrix3d yaw_rotation(double yaw) { return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).matrix(); }

/// The world ray through pixel (u, v): origin and direction scaled so that its camera z component is 1.
inline void pixel_ray(const Scene& s, double u, double v, Eigen::Vector3d& o, Eigen::Vector3d& d) {
  o = s.world_from_camera.translation();
  d = s.world_from_camera.linear() * Eigen::Vector3d((u - s.K.cx) / s.K.fx, (v - s.K.cy) / s.K.fy, 1.0);
}

/// Nearest hit along o + t d (t > 0): t, the object's id and the surface normal. False on a miss.
inline bool cast(const Scene& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double& t_hit, int& id,
                 Eigen::Vector3d& normal) {
  t_hit = std::numeric_limits<double>::infinity();
  id = -1;
  if (s.table && std::abs(d.z()) > 1e-12) {
    const double t = (s.table_z - o.z()) / d.z();
    if (t > 0 && t < t_hit) {
      t_hit = t;
      id = 0;
      normal = Eigen::Vector3d::UnitZ();
    }
  }
  for (std::size_t i = 0; i < s.boxes.size(); ++i) {
    const Box& b = s.boxes[i];
    const Eigen::Matrix3d R = yaw_rotation(b.yaw);
    const Eigen::Vector3d ob = R.transpose() * (o - b.centre), db = R.transpose() * d;
    double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
    int axis = -1;
    double sign = 0;
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      const double h = 0.5 * b.size[a];
      if (std::abs(db[a]) < 1e-15) {
        if (std::abs(ob[a]) > h) miss = true;
        continue;
      }
      double ta = (-h - ob[a]) / db[a], tb = (h - ob[a]) / db[a];
      double sa = -1;
      if (ta > tb) {
        std::swap(ta, tb);
        sa = 1;
      }
      if (ta > t0) {
        t0 = ta;
        axis = a;
        sign = sa;
      }
      t1 = std::min(t1, tb);
    }
    if (miss || t0 > t1 || t0 <= 0 || axis < 0 || t0 >= t_hit) continue;
    t_hit = t0;
    id = static_cast<int>(i) + 1;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[axis] = sign;
    normal = R * n;
  }
  for (std::size_t i = 0; i < s.cylinders.size(); ++i) {
    const Cylinder& c = s.cylinders[i];
    const int cid = static_cast<int>(s.boxes.size() + i) + 1;
    const Eigen::Vector3d q = o - c.base_centre;
    // Side: |(q + t d)_xy| = r.
    const double A = d.x() * d.x() + d.y() * d.y(), B = 2 * (q.x() * d.x() + q.y() * d.y()),
                 C = q.x() * q.x() + q.y() * q.y() - c.radius * c.radius;
    if (A > 1e-15) {
      const double disc = B * B - 4 * A * C;
      if (disc >= 0) {
        const double t = (-B - std::sqrt(disc)) / (2 * A);
        const double z = q.z() + t * d.z();
        if (t > 0 && t < t_hit && z >= 0 && z <= c.height) {
          t_hit = t;
          id = cid;
          normal = Eigen::Vector3d(q.x() + t * d.x(), q.y() + t * d.y(), 0).normalized();
        }
      }
    }
    // Top cap.
    if (std::abs(d.z()) > 1e-15) {
      const double t = (c.height - q.z()) / d.z();
      const double x = q.x() + t * d.x(), y = q.y() + t * d.y();
      if (t > 0 && t < t_hit && x * x + y * y <= c.radius * c.radius) {
        t_hit = t;
        id = cid;
        normal = Eigen::Vector3d::UnitZ();
      }
    }
  }
  return id >= 0;
}

inline Rendered render(const Scene& s, const Noise& noise = {}) {
  Rendered r;
  r.frame.K = s.K;
  r.frame.world_from_camera = s.world_from_camera;
  r.frame.rgb = cv::Mat(s.K.height, s.K.width, CV_8UC3, cv::Scalar(0, 0, 0));
  r.frame.depth = cv::Mat(s.K.height, s.K.width, CV_16UC1, cv::Scalar(0));
  r.ids = cv::Mat1i(s.K.height, s.K.width, -1);
  r.exact_depth_m = cv::Mat1d(s.K.height, s.K.width, 0.0);
  std::mt19937 rng(noise.seed);
  std::normal_distribution<double> colour_noise(0, noise.colour_sigma > 0 ? noise.colour_sigma : 1);
  std::normal_distribution<double> depth_noise(0, noise.depth_sigma_mm > 0 ? noise.depth_sigma_mm : 1);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (int v = 0; v < s.K.height; ++v) {
    for (int u = 0; u < s.K.width; ++u) {
      Eigen::Vector3d o, d, n;
      pixel_ray(s, u, v, o, d);
      double t = 0;
      int id = -1;
      if (!cast(s, o, d, t, id, n)) continue;
      r.ids(v, u) = id;
      r.exact_depth_m(v, u) = t;  // d has camera z = 1: t is the depth
      double mm = t * 1000.0;
      if (noise.depth_sigma_mm > 0) mm += depth_noise(rng);
      if (noise.depth_dropout > 0 && uniform(rng) < noise.depth_dropout) mm = 0;
      r.frame.depth.at<std::uint16_t>(v, u) = cv::saturate_cast<std::uint16_t>(std::lround(mm));
      const cv::Vec3b base = id == 0 ? s.table_rgb
                             : id <= static_cast<int>(s.boxes.size())
                                 ? s.boxes[static_cast<std::size_t>(id - 1)].rgb
                                 : s.cylinders[static_cast<std::size_t>(id - 1) - s.boxes.size()].rgb;
      const double shade = s.ambient + (1 - s.ambient) * std::max(0.0, n.dot(s.light));
      cv::Vec3b& px = r.frame.rgb.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) {
        double value = base[c] * shade;
        if (noise.colour_sigma > 0) value += colour_noise(rng);
        px[c] = cv::saturate_cast<unsigned char>(value);
      }
    }
  }
  if (noise.salt_pepper > 0) {
    std::uniform_int_distribution<int> byte(0, 255);
    for (int v = 0; v < s.K.height; ++v)
      for (int u = 0; u < s.K.width; ++u)
        if (uniform(rng) < noise.salt_pepper) {
          cv::Vec3b& px = r.frame.rgb.at<cv::Vec3b>(v, u);
          for (int c = 0; c < 3; ++c) px[c] = static_cast<unsigned char>(byte(rng));
        }
  }
  return r;
}

/// The pixels of object `id` as a mask (255 = in).
inline cv::Mat1b id_mask(const Rendered& r, int id) {
  cv::Mat1b m;
  cv::compare(r.ids, id, m, cv::CMP_EQ);
  return m;
}

/// The pixels of object `id` whose surface lies higher than `min_z` (world): e.g. its top face.
inline cv::Mat1b id_mask_above(const Rendered& r, int id, double min_z) {
  cv::Mat1b m(r.ids.size(), 0);
  const RgbdFrame& f = r.frame;
  for (int v = 0; v < m.rows; ++v)
    for (int u = 0; u < m.cols; ++u) {
      if (r.ids(v, u) != id) continue;
      const double z = r.exact_depth_m(v, u);
      const Eigen::Vector3d p = f.world_from_camera * Eigen::Vector3d((u - f.K.cx) / f.K.fx * z, (v - f.K.cy) / f.K.fy * z, z);
      if (p.z() > min_z) m(v, u) = 255;
    }
  return m;
}

inline double iou(const cv::Mat1b& a, const cv::Mat1b& b) {
  const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 0.0;
}

/// A workcell camera 0.75 m from the table centre, 50 degrees below the horizon.
inline Eigen::Isometry3d workcell_camera() {
  return look_at(Eigen::Vector3d(0.0, -0.48, 0.58), Eigen::Vector3d(0.0, 0.0, 0.0));
}

}  // namespace dh::perception::synth
