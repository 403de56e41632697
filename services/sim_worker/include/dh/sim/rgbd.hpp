// RGB-D workcell cameras: their configuration (configs/cameras.yaml), pinhole intrinsics from MuJoCo's
// field of view, poses in OpenCV's camera convention, and metric depth from MuJoCo's depth buffer.
//
// Conventions are the perception library's (services/perception/include/dh/perception/frame.hpp):
//   camera frame  OpenCV: x right, y down, z forward along the optical axis (MuJoCo's camera: x right,
//                 y up, looking along -z; so R_opencv = R_mujoco * diag(1, -1, -1))
//   pixels        row-major, top row first; integer (u, v) is a pixel centre, its ray ((u-cx)/fx, (v-cy)/fy,
//   1) depth         millimetres along the optical axis (z, not the ray length), uint16, 0 = no reading
//
// MuJoCo 2.2 renders a fixed camera through a symmetric OpenGL frustum: vertical field of view fovy,
// horizontal extent from the viewport's aspect ratio (square pixels), near and far planes at
// m->vis.map.znear * m->stat.extent and m->vis.map.zfar * m->stat.extent. OpenGL maps the frustum's left
// edge to the left edge of pixel 0, so the optical axis passes through (width / 2, height / 2) in edge
// coordinates, i.e. cx = (width - 1) / 2, cy = (height - 1) / 2 in pixel-centre coordinates, and
// fx = fy = (height / 2) / tan(fovy / 2).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "dh/sim/scene.hpp"

struct mjModel_;
struct mjData_;

namespace dh::sim {

/// The RGB-D camera configs/cameras.yaml describes by default.
inline constexpr const char* kWorkcellRgbdCamera = "workcell";

struct Pinhole {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
};

/// world_from_camera in the OpenCV camera convention: p_world = R(wxyz) * p_camera + position.
struct CameraPose {
  std::array<double, 3> position{};
  std::array<double, 4> wxyz{1, 0, 0, 0};
};

/// Intrinsics of MuJoCo's (OpenGL's) symmetric frustum: vertical field of view `fovy_deg`, width x height
/// square pixels. Throws std::invalid_argument for a size < 1 or fovy outside (0, 180).
Pinhole pinhole_from_fovy(double fovy_deg, int width, int height);

/// The OpenCV-convention pose of a MuJoCo camera from its world position and orientation matrix
/// (mjData::cam_xpos, cam_xmat: row-major, columns = the camera's x, y, z axes in the world).
CameraPose opencv_pose_from_mujoco(const double xpos[3], const double xmat[9]);

/// Row-major rotation matrix of a unit quaternion w, x, y, z.
std::array<double, 9> rotation_matrix(const std::array<double, 4>& wxyz);

/// A world point in the camera frame (OpenCV convention).
std::array<double, 3> camera_from_world(const CameraPose& pose, const std::array<double, 3>& p_world);

/// Where a world point appears: column u, row v (pixel-centre coordinates) and its depth z along the
/// optical axis (m; negative: behind the camera, u and v then meaningless).
struct Projection {
  double u = 0, v = 0, z = 0;
};
Projection project(const Pinhole& K, const CameraPose& pose, const std::array<double, 3>& p_world);

/// The world point seen at pixel (u, v) with depth z (m) along the optical axis.
std::array<double, 3> back_project(const Pinhole& K, const CameraPose& pose, double u, double v, double z);

/// Distance along the optical axis (m) of an OpenGL window depth `d` in [0, 1] (the value
/// glReadPixels(GL_DEPTH_COMPONENT, GL_FLOAT) and mjr_readPixels give) for a perspective frustum with
/// near and far planes `znear`, `zfar` (m): z = znear * zfar / (zfar - d * (zfar - znear)).
double linear_depth(double d, double znear, double zfar);

/// linear_depth in whole millimetres, rounded; 0 (no reading) at or beyond the far plane (d >= 1: nothing
/// was drawn there) and beyond 65.535 m.
std::uint16_t depth_to_mm(float d, double znear, double zfar);

/// A whole depth buffer as read from OpenGL (bottom row first) to millimetres, top row first.
void depth_buffer_to_mm(const float* bottom_up, int width, int height, double znear, double zfar,
                        std::uint16_t* top_down_mm);

/// Near and far planes (m) MuJoCo renders a model with: vis.map.znear/zfar scaled by stat.extent.
std::array<double, 2> model_clip_planes(const mjModel_* m);

/// A camera's intrinsics and pose in the model's current state (mj_forward or a step computed them).
/// Throws std::invalid_argument when the model has no camera `name`.
Pinhole camera_pinhole(const mjModel_* m, const std::string& name, int width, int height);
CameraPose camera_pose(const mjModel_* m, const mjData_* d, const std::string& name);

/// configs/cameras.yaml: the RGB-D cameras sim_worker adds to every scene's model, each with optional
/// per-scene overrides of any of its keys:
///
///   rgbd_cameras:
///     - name: workcell
///       width: 640                 # pixels
///       height: 480
///       fovy: 45                   # vertical field of view, degrees
///       pos: [0.75, 0.0, 1.35]     # m, world frame (table centre, top at z = 0, robot at -x)
///       look_at: [-0.1, 0.0, 0.0]  # the point on the optical axis; the world's z is up in the image
///       scenes:                    # optional, by scene name (configs/scenes/<file>: `scene:`)
///         kitchen_goal: {pos: [0.8, 0.1, 1.3]}
struct CamerasConfig {
  struct Entry {
    CameraSpec camera;
    std::map<std::string, CameraSpec> per_scene;  ///< the camera with that scene's overrides applied
  };
  std::filesystem::path file;
  std::vector<Entry> cameras;
  /// Every camera as placed in scene `scene_name`.
  std::vector<CameraSpec> for_scene(const std::string& scene_name) const;
  bool has(const std::string& camera) const;
};

/// Loads and checks the file; throws ConfigError naming the file and key: sizes below 1, fovy outside
/// (0, 180), look_at equal to pos or straight above or below it, duplicate or empty names.
CamerasConfig load_cameras_config(const std::filesystem::path& file);

}  // namespace dh::sim
