// Offscreen camera images of a workcell, for model backends (policy server, VLM planner) and perception.
//
// Rendering runs headless on Mesa's surfaceless EGL platform (llvmpipe on this machine; no display, no
// window): a GlContext is one OpenGL context, current on one thread at a time; a CameraRig holds what
// MuJoCo's renderer keeps per model (mjrContext, mjvScene) on the context current on its thread, and
// renders the model's named cameras to RGB8. The workcell model carries two cameras (scene_mjcf):
//   agentview  fixed, in front of the table (+x), looking back over the workspace towards the robot
//   wrist      on the hand, looking along the tool axis, the fingertips at the bottom of the image
// plus, in sim_worker, the RGB-D cameras of configs/cameras.yaml (rgbd.hpp: "workcell", 640 x 480), which
// render colour and metric depth (render(index, image, depth_mm)).
// Images are upright: row-major, top row first (not OpenGL's bottom-up order), no 180° rotation.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

struct mjModel_;
struct mjData_;
struct mjvCamera_;

namespace dh::sim {

class Workcell;

inline constexpr const char* kAgentviewCamera = "agentview";
inline constexpr const char* kWristCamera = "wrist";
/// Every camera the workcell model carries, in a stable order.
const std::vector<std::string>& workcell_cameras();
/// Default image size (openpi's policies take 224 × 224).
inline constexpr int kDefaultCameraSize = 224;

/// Rendering is not available or was asked for something impossible; the message names what is missing.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An RGB8 image: row-major, top row first, 3 octets per pixel, no padding.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  const std::uint8_t* pixel(int row, int col) const { return rgb.data() + 3 * (row * width + col); }
};

/// One OpenGL context on Mesa's surfaceless EGL platform. Created current nowhere; make it current on
/// the thread that renders. Copy and move are deleted (the context is a thread's resource).
class GlContext {
 public:
  /// Throws RenderError naming what is missing: libEGL's surfaceless platform, an EGL display, a
  /// pbuffer-capable RGB config, the desktop OpenGL API, or the context itself.
  GlContext();
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  /// Makes the context current on the calling thread (it must not be current on another one).
  void make_current();
  /// The calling thread lets the context go, so another thread may make it current.
  void release();
  /// "EGL <version> <vendor>; OpenGL <version>; <renderer>" (GL strings only while current).
  std::string description() const;

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
};

/// MuJoCo's GPU state for one workcell's model, on the GL context current on the constructing thread;
/// render, and destroy it, on that thread with that context current.
class CameraRig {
 public:
  /// Throws RenderError when no context is current, a camera is not in the model, or the size
  /// exceeds the model's offscreen buffer (<visual><global offwidth offheight>).
  CameraRig(const Workcell& cell, std::vector<std::string> cameras, int width, int height);
  /// The same for any model; `d` must outlive the rig. mjv_updateScene takes a mutable mjData only to
  /// borrow its scratch stack: rendering never changes the physics state.
  CameraRig(const mjModel_* m, mjData_* d, std::vector<std::string> cameras, int width, int height);
  ~CameraRig();
  CameraRig(const CameraRig&) = delete;
  CameraRig& operator=(const CameraRig&) = delete;

  /// The model rendered (a rig belongs to one workcell's model).
  const mjModel_* model() const { return m_; }
  const std::vector<std::string>& cameras() const { return cameras_; }
  int width() const { return width_; }
  int height() const { return height_; }

  /// Renders camera `index` (into cameras()) of the cell's current state into `out` (resized).
  void render(std::size_t index, Image& out);
  Image render(std::size_t index) {
    Image out;
    render(index, out);
    return out;
  }
  /// The view from `pos` (world frame, m) towards `look_at`, the world's z up in the image, with the
  /// model's default vertical field of view (<visual><global fovy>): a viewpoint the model has no camera
  /// for, such as an RGB-D camera of configs/cameras.yaml that sim_worker adds only to its own models.
  void render_from(const std::array<double, 3>& pos, const std::array<double, 3>& look_at, Image& out);
  /// The same, with the depth image registered to it: `depth_mm` gets height x width values, top row
  /// first, millimetres along the optical axis, 0 where nothing was drawn (rgbd.hpp linearises MuJoCo's
  /// depth buffer with the model's clip planes).
  void render(std::size_t index, Image& out, std::vector<std::uint16_t>& depth_mm);

 private:
  struct Gpu;
  const mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::vector<std::string> cameras_;
  int width_ = 0, height_ = 0;
  std::unique_ptr<Gpu> gpu_;
  void render_to(const mjvCamera_& camera, Image& out, std::vector<std::uint16_t>* depth_mm);
  std::vector<std::uint8_t> bottom_up_;  ///< glReadPixels' row order
  std::vector<float> depth_bottom_up_;
};

/// The start-up check of a process that will render: makes `gl` current on the calling thread, renders
/// a small built-in scene at width × height, checks the image is not black, and releases `gl` again.
/// Returns gl.description(). Throws RenderError with what failed.
std::string check_rendering(GlContext& gl, int width, int height);

}  // namespace dh::sim
