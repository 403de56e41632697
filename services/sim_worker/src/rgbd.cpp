#include "dh/sim/rgbd.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "dh/common/config.hpp"
#include "dh/sim/camera.hpp"
#include "dh/sim/config_arrays.hpp"

namespace dh::sim {

Pinhole pinhole_from_fovy(double fovy_deg, int width, int height) {
  if (width < 1 || height < 1)
    throw std::invalid_argument("image size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is not positive");
  if (!(fovy_deg > 0 && fovy_deg < 180))
    throw std::invalid_argument("fovy " + std::to_string(fovy_deg) + " is not within (0, 180) degrees");
  Pinhole K;
  K.width = width;
  K.height = height;
  K.fy = (height / 2.0) / std::tan(fovy_deg * M_PI / 360.0);
  K.fx = K.fy;  // square pixels: the horizontal extent follows the aspect ratio
  K.cx = (width - 1) / 2.0;
  K.cy = (height - 1) / 2.0;
  return K;
}

CameraPose opencv_pose_from_mujoco(const double xpos[3], const double xmat[9]) {
  // OpenCV's axes in the world: x = MuJoCo's x, y = -MuJoCo's y, z = -MuJoCo's z (columns of xmat).
  double R[9];
  for (int r = 0; r < 3; ++r) {
    R[3 * r + 0] = xmat[3 * r + 0];
    R[3 * r + 1] = -xmat[3 * r + 1];
    R[3 * r + 2] = -xmat[3 * r + 2];
  }
  CameraPose pose;
  std::copy(xpos, xpos + 3, pose.position.begin());
  double q[4];
  mju_mat2Quat(q, R);
  mju_normalize4(q);
  if (q[0] < 0)
    for (double& v : q) v = -v;  // one of the two equal quaternions, w >= 0
  std::copy(q, q + 4, pose.wxyz.begin());
  return pose;
}

std::array<double, 9> rotation_matrix(const std::array<double, 4>& wxyz) {
  const double n = std::sqrt(wxyz[0] * wxyz[0] + wxyz[1] * wxyz[1] + wxyz[2] * wxyz[2] + wxyz[3] * wxyz[3]);
  if (!(n > 0)) throw std::invalid_argument("a zero quaternion is no rotation");
  const double w = wxyz[0] / n, x = wxyz[1] / n, y = wxyz[2] / n, z = wxyz[3] / n;
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

std::array<double, 3> camera_from_world(const CameraPose& pose, const std::array<double, 3>& p) {
  const auto R = rotation_matrix(pose.wxyz);
  const double v[3] = {p[0] - pose.position[0], p[1] - pose.position[1], p[2] - pose.position[2]};
  // R^T v
  return {R[0] * v[0] + R[3] * v[1] + R[6] * v[2], R[1] * v[0] + R[4] * v[1] + R[7] * v[2],
          R[2] * v[0] + R[5] * v[1] + R[8] * v[2]};
}

Projection project(const Pinhole& K, const CameraPose& pose, const std::array<double, 3>& p_world) {
  const auto c = camera_from_world(pose, p_world);
  Projection out;
  out.z = c[2];
  if (c[2] != 0) {
    out.u = K.cx + K.fx * c[0] / c[2];
    out.v = K.cy + K.fy * c[1] / c[2];
  }
  return out;
}

std::array<double, 3> back_project(const Pinhole& K, const CameraPose& pose, double u, double v, double z) {
  const double c[3] = {(u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z};
  const auto R = rotation_matrix(pose.wxyz);
  std::array<double, 3> p;
  for (int r = 0; r < 3; ++r)
    p[r] = R[3 * r] * c[0] + R[3 * r + 1] * c[1] + R[3 * r + 2] * c[2] + pose.position[r];
  return p;
}

double linear_depth(double d, double znear, double zfar) {
  return znear * zfar / (zfar - d * (zfar - znear));
}

std::uint16_t depth_to_mm(float d, double znear, double zfar) {
  if (!(d < 1.0f) || d < 0.0f) return 0;  // the cleared far plane: nothing drawn (also NaN)
  const double mm = std::round(1000.0 * linear_depth(d, znear, zfar));
  return mm >= 1 && mm <= 65535 ? static_cast<std::uint16_t>(mm) : 0;
}

void depth_buffer_to_mm(const float* bottom_up, int width, int height, double znear, double zfar,
                        std::uint16_t* top_down_mm) {
  for (int r = 0; r < height; ++r) {
    const float* src = bottom_up + static_cast<std::size_t>(height - 1 - r) * width;
    std::uint16_t* dst = top_down_mm + static_cast<std::size_t>(r) * width;
    for (int c = 0; c < width; ++c) dst[c] = depth_to_mm(src[c], znear, zfar);
  }
}

std::array<double, 2> model_clip_planes(const mjModel* m) {
  return {m->vis.map.znear * m->stat.extent, m->vis.map.zfar * m->stat.extent};
}

namespace {
int camera_id(const mjModel* m, const std::string& name) {
  const int id = mj_name2id(m, mjOBJ_CAMERA, name.c_str());
  if (id < 0) throw std::invalid_argument("the model has no camera '" + name + "'");
  return id;
}
}  // namespace

Pinhole camera_pinhole(const mjModel* m, const std::string& name, int width, int height) {
  return pinhole_from_fovy(m->cam_fovy[camera_id(m, name)], width, height);
}

CameraPose camera_pose(const mjModel* m, const mjData* d, const std::string& name) {
  const int id = camera_id(m, name);
  return opencv_pose_from_mujoco(d->cam_xpos + 3 * id, d->cam_xmat + 9 * id);
}

// ---- configs/cameras.yaml ----------------------------------------------------------------------------

namespace {

/// `base` with the keys `n` sets.
CameraSpec read_camera(const ConfigNode& n, CameraSpec base, bool complete) {
  if (complete) {
    base.name = n.get<std::string>("name");
    if (base.name.empty()) n.fail("name", "a camera needs a name");
    for (const auto& taken : workcell_cameras())
      if (base.name == taken)
        n.fail("name", "'" + base.name + "' is already a camera of every workcell model");
  }
  auto need = [&](const char* key) {
    if (complete && !n.has(key)) n.fail(key, "missing");
  };
  need("pos");
  need("look_at");
  if (n.has("pos")) base.pos = get_array<3>(n, "pos");
  if (n.has("look_at")) base.look_at = get_array<3>(n, "look_at");
  base.fovy = n.get_or<double>("fovy", base.fovy);
  base.width = n.get_or<int>("width", base.width);
  base.height = n.get_or<int>("height", base.height);
  if (base.width < 1 || base.height < 1 || base.width > 4096 || base.height > 4096)
    n.fail(n.has("width") ? "width" : "height", "the image size must be 1..4096 pixels per side");
  if (!(base.fovy > 0 && base.fovy < 180))
    n.fail("fovy", "the vertical field of view must be within (0, 180) degrees");
  const double f[3] = {base.look_at[0] - base.pos[0], base.look_at[1] - base.pos[1],
                       base.look_at[2] - base.pos[2]};
  if (std::hypot(f[0], f[1]) < 1e-6 * std::max(1.0, std::abs(f[2])))
    n.fail("look_at", "must not lie straight above or below pos (the image's up would be undefined)");
  return base;
}

}  // namespace

CamerasConfig load_cameras_config(const std::filesystem::path& file) {
  const ConfigNode root = ConfigNode::load_file(file);
  CamerasConfig c;
  c.file = file;
  for (const ConfigNode& n : root.items("rgbd_cameras")) {
    CamerasConfig::Entry e;
    e.camera = read_camera(n, CameraSpec{}, true);
    for (const auto& other : c.cameras)
      if (other.camera.name == e.camera.name)
        n.fail("name", "camera '" + e.camera.name + "' is defined twice");
    if (n.has("scenes")) {
      const ConfigNode scenes = n.child("scenes");
      for (const auto& scene : scenes.keys())
        e.per_scene[scene] = read_camera(scenes.child(scene), e.camera, false);
    }
    c.cameras.push_back(std::move(e));
  }
  return c;
}

std::vector<CameraSpec> CamerasConfig::for_scene(const std::string& scene_name) const {
  std::vector<CameraSpec> out;
  for (const auto& e : cameras) {
    const auto it = e.per_scene.find(scene_name);
    out.push_back(it == e.per_scene.end() ? e.camera : it->second);
  }
  return out;
}

bool CamerasConfig::has(const std::string& camera) const {
  return std::any_of(cameras.begin(), cameras.end(), [&](const Entry& e) { return e.camera.name == camera; });
}

}  // namespace dh::sim
