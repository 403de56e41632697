#include "dh/sim/camera.hpp"

#include <mujoco/mujoco.h>
#if DH_HAVE_EGL
#include <EGL/egl.h>
#include <EGL/eglext.h>
#endif

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <mutex>
#include <utility>

#include "dh/sim/model.hpp"
#include "dh/sim/rgbd.hpp"
#include "dh/sim/workcell.hpp"

namespace dh::sim {

namespace {

// glGetString's names (GL/gl.h), so this file needs no GL headers: MuJoCo loads GL itself.
constexpr unsigned kGlVendor = 0x1F00, kGlRenderer = 0x1F01, kGlVersion = 0x1F02;
using GetString = const unsigned char* (*)(unsigned);

// MuJoCo loads its GL function pointers (process globals) in mjr_makeContext; channels' threads build
// rigs concurrently, so making and freeing GPU state is serialised.
std::mutex& mjr_mutex() {
  static std::mutex m;
  return m;
}

#if DH_HAVE_EGL
std::string egl_error() {
  static constexpr std::pair<EGLint, const char*> kNames[] = {{EGL_SUCCESS, "EGL_SUCCESS"},
                                                              {EGL_NOT_INITIALIZED, "EGL_NOT_INITIALIZED"},
                                                              {EGL_BAD_ACCESS, "EGL_BAD_ACCESS"},
                                                              {EGL_BAD_ALLOC, "EGL_BAD_ALLOC"},
                                                              {EGL_BAD_ATTRIBUTE, "EGL_BAD_ATTRIBUTE"},
                                                              {EGL_BAD_CONFIG, "EGL_BAD_CONFIG"},
                                                              {EGL_BAD_CONTEXT, "EGL_BAD_CONTEXT"},
                                                              {EGL_BAD_DISPLAY, "EGL_BAD_DISPLAY"},
                                                              {EGL_BAD_MATCH, "EGL_BAD_MATCH"},
                                                              {EGL_BAD_PARAMETER, "EGL_BAD_PARAMETER"},
                                                              {EGL_BAD_SURFACE, "EGL_BAD_SURFACE"}};
  const EGLint e = eglGetError();
  for (const auto& [code, name] : kNames)
    if (code == e) return name;
  return "EGL error " + std::to_string(e);
}

/// The process's surfaceless EGL display, initialised once and kept for the process's life (another
/// thread's context may use it at any time, so it is never terminated).
EGLDisplay surfaceless_display() {
  static const std::pair<EGLDisplay, std::string> d = []() -> std::pair<EGLDisplay, std::string> {
    const char* ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!ext || !std::strstr(ext, "EGL_MESA_platform_surfaceless"))
      return {
          EGL_NO_DISPLAY,
          "libEGL offers no surfaceless platform (client extension EGL_MESA_platform_surfaceless missing; "
          "Debian: install libegl-mesa0 and libgl1-mesa-dri)"};
    EGLDisplay dpy = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy == EGL_NO_DISPLAY)
      return {EGL_NO_DISPLAY,
              "eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA) gave no display: " + egl_error()};
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor))
      return {EGL_NO_DISPLAY, "eglInitialize on the surfaceless display failed: " + egl_error() +
                                  " (Mesa's llvmpipe driver comes with libgl1-mesa-dri)"};
    return {dpy, ""};
  }();
  if (d.first == EGL_NO_DISPLAY) throw RenderError("headless rendering unavailable: " + d.second);
  return d.first;
}

/// The running GL's glGetString, or null.
GetString gl_get_string() { return reinterpret_cast<GetString>(eglGetProcAddress("glGetString")); }
bool context_current() { return eglGetCurrentContext() != EGL_NO_CONTEXT; }
#else
// Built without libegl-dev: every attempt to render says so (sim_worker without --cameras still runs).
constexpr const char* kNoEgl =
    "headless rendering unavailable: this build has no EGL (libegl-dev was missing when CMake ran); "
    "install libegl-dev libegl-mesa0 libgl1-mesa-dri and rebuild";
GetString gl_get_string() { return nullptr; }
bool context_current() { throw RenderError(kNoEgl); }
#endif

/// A camera of the render check: straight down on a red box lit from above.
std::string check_model(int width, int height) {
  return "<mujoco model=\"dh_render_check\">\n<visual><global offwidth=\"" + std::to_string(width) +
         "\" offheight=\"" + std::to_string(height) +
         "\"/></visual>\n<worldbody>\n<light pos=\"0 0 2\" dir=\"0 0 -1\" directional=\"true\"/>\n"
         "<geom type=\"box\" size=\"0.3 0.3 0.1\" rgba=\"0.9 0.1 0.1 1\"/>\n"
         "<camera name=\"check\" pos=\"0 0 1.5\" fovy=\"45\"/>\n</worldbody>\n</mujoco>\n";
}

}  // namespace

const std::vector<std::string>& workcell_cameras() {
  static const std::vector<std::string> names{kAgentviewCamera, kWristCamera};
  return names;
}

// ---- GlContext ---------------------------------------------------------------------------------------
#if DH_HAVE_EGL

GlContext::GlContext() {
  EGLDisplay dpy = surfaceless_display();
  // Without EGL_PBUFFER_BIT Mesa's surfaceless platform matches no config at all.
  // clang-format off
  const EGLint attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                            EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_NONE};
  // clang-format on
  EGLConfig config = nullptr;
  EGLint n = 0;
  if (!eglChooseConfig(dpy, attribs, &config, 1, &n) || n < 1)
    throw RenderError("EGL has no pbuffer-capable RGB8/depth-24 OpenGL config on the surfaceless display (" +
                      egl_error() + ")");
  if (!eglBindAPI(EGL_OPENGL_API))
    throw RenderError("EGL cannot bind the desktop OpenGL API (" + egl_error() +
                      "); MuJoCo needs OpenGL, not GLES");
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, nullptr);
  if (ctx == EGL_NO_CONTEXT) throw RenderError("eglCreateContext failed: " + egl_error());
  display_ = dpy;
  context_ = ctx;
}

GlContext::~GlContext() {
  if (!context_) return;
  if (eglGetCurrentContext() == context_) release();
  eglDestroyContext(display_, context_);  // deferred by EGL while current on another thread
}

void GlContext::make_current() {
  // The bound API is per thread, and eglGetCurrentContext answers for the bound API.
  if (!eglBindAPI(EGL_OPENGL_API)) throw RenderError("eglBindAPI(EGL_OPENGL_API) failed: " + egl_error());
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    throw RenderError("eglMakeCurrent without a surface failed: " + egl_error() +
                      " (is the context current on another thread?)");
}

void GlContext::release() { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT); }

std::string GlContext::description() const {
  const char* egl_version = eglQueryString(display_, EGL_VERSION);
  std::string s = std::string("EGL ") + (egl_version ? egl_version : "?");
  if (eglGetCurrentContext() != context_) return s;
  if (auto gl_string = gl_get_string()) {
    auto str = [&](unsigned name) {
      const unsigned char* v = gl_string(name);
      return v ? std::string(reinterpret_cast<const char*>(v)) : std::string("?");
    };
    s += "; OpenGL " + str(kGlVersion) + "; " + str(kGlVendor) + " " + str(kGlRenderer);
  }
  return s;
}
#else
GlContext::GlContext() { throw RenderError(kNoEgl); }
GlContext::~GlContext() = default;
void GlContext::make_current() { throw RenderError(kNoEgl); }
void GlContext::release() {}
std::string GlContext::description() const { return "no EGL"; }
#endif

// ---- CameraRig ---------------------------------------------------------------------------------------

struct CameraRig::Gpu {
  mjvScene scene;
  mjrContext context;
  mjvOption option;
  mjvPerturb perturb;
  std::vector<int> camera_ids;
};

CameraRig::CameraRig(const Workcell& cell, std::vector<std::string> cameras, int width, int height)
    : CameraRig(cell.model(), const_cast<mjData_*>(cell.data()), std::move(cameras), width, height) {}

CameraRig::CameraRig(const mjModel_* m, mjData_* d, std::vector<std::string> cameras, int width, int height)
    : m_(m),
      d_(d),
      cameras_(std::move(cameras)),
      width_(width),
      height_(height),
      gpu_(std::make_unique<Gpu>()) {
  if (!context_current())
    throw RenderError("no OpenGL context is current on this thread (make a GlContext current first)");
  for (const auto& name : cameras_) {
    const int id = mj_name2id(m_, mjOBJ_CAMERA, name.c_str());
    if (id < 0) {
      std::string have;
      for (int c = 0; c < m_->ncam; ++c)
        have += std::string(have.empty() ? "" : ", ") + mj_id2name(m_, mjOBJ_CAMERA, c);
      throw RenderError("the model has no camera '" + name + "' (it has: " + (have.empty() ? "none" : have) +
                        ")");
    }
    gpu_->camera_ids.push_back(id);
  }
  if (width_ < 1 || height_ < 1 || width_ > m_->vis.global.offwidth || height_ > m_->vis.global.offheight)
    throw RenderError("image size " + std::to_string(width_) + "x" + std::to_string(height_) +
                      " does not fit the model's offscreen buffer " +
                      std::to_string(m_->vis.global.offwidth) + "x" +
                      std::to_string(m_->vis.global.offheight) + " (<visual><global offwidth offheight>)");
  mjv_defaultOption(&gpu_->option);
  // Sites are markers (the TCP, regions, grips), not things a camera sees.
  std::fill(std::begin(gpu_->option.sitegroup), std::end(gpu_->option.sitegroup), 0);
  mjv_defaultPerturb(&gpu_->perturb);
  mjv_defaultScene(&gpu_->scene);
  mjr_defaultContext(&gpu_->context);
  std::lock_guard lock(mjr_mutex());
  // Room for every geom and site, so a frame never drops one (nor flags mjWARN_VGEOMFULL in mjData).
  mjv_makeScene(m_, &gpu_->scene, 2 * (m_->ngeom + m_->nsite) + 200);
  mjr_makeContext(m_, &gpu_->context, mjFONTSCALE_50);
  mjr_setBuffer(mjFB_OFFSCREEN, &gpu_->context);
  if (gpu_->context.currentBuffer != mjFB_OFFSCREEN) {
    mjr_freeContext(&gpu_->context);
    mjv_freeScene(&gpu_->scene);
    throw RenderError("the OpenGL context has no offscreen framebuffer for MuJoCo");
  }
}

CameraRig::~CameraRig() {
  std::lock_guard lock(mjr_mutex());
  mjr_freeContext(&gpu_->context);
  mjv_freeScene(&gpu_->scene);
}

namespace {
mjvCamera fixed_camera(int id) {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = id;
  return cam;
}
}  // namespace

void CameraRig::render(std::size_t index, Image& out) {
  const mjvCamera cam = fixed_camera(gpu_->camera_ids.at(index));
  render_to(cam, out, nullptr);
}

void CameraRig::render(std::size_t index, Image& out, std::vector<std::uint16_t>& depth_mm) {
  const mjvCamera cam = fixed_camera(gpu_->camera_ids.at(index));
  render_to(cam, out, &depth_mm);
}

void CameraRig::render_from(const std::array<double, 3>& pos, const std::array<double, 3>& look_at, Image& out) {
  // MuJoCo's free camera sits `distance` behind `lookat` along the direction given by azimuth and elevation.
  const double dx = look_at[0] - pos[0], dy = look_at[1] - pos[1], dz = look_at[2] - pos[2];
  const double distance = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (distance <= 0) throw RenderError("a view needs a point to look at other than where it stands");
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FREE;
  for (int i = 0; i < 3; ++i) cam.lookat[i] = look_at[i];
  cam.distance = distance;
  cam.azimuth = std::atan2(dy, dx) * 180.0 / M_PI;
  cam.elevation = std::asin(dz / distance) * 180.0 / M_PI;
  render_to(cam, out, nullptr);
}

void CameraRig::render_to(const mjvCamera& camera, Image& out, std::vector<std::uint16_t>* depth_mm) {
  mjvCamera cam = camera;
  mjv_updateScene(m_, d_, &gpu_->option, &gpu_->perturb, &cam, mjCAT_ALL, &gpu_->scene);
  const mjrRect viewport{0, 0, width_, height_};
  mjr_setBuffer(mjFB_OFFSCREEN, &gpu_->context);
  mjr_render(viewport, &gpu_->scene, &gpu_->context);
  const std::size_t row = 3 * static_cast<std::size_t>(width_);
  bottom_up_.resize(row * height_);
  if (depth_mm) depth_bottom_up_.resize(static_cast<std::size_t>(width_) * height_);
  mjr_readPixels(bottom_up_.data(), depth_mm ? depth_bottom_up_.data() : nullptr, viewport, &gpu_->context);
  if (depth_mm) {
    const auto [znear, zfar] = model_clip_planes(m_);
    depth_mm->resize(depth_bottom_up_.size());
    depth_buffer_to_mm(depth_bottom_up_.data(), width_, height_, znear, zfar, depth_mm->data());
  }
  out.width = width_;
  out.height = height_;
  out.rgb.resize(bottom_up_.size());
  for (int r = 0; r < height_; ++r)
    std::memcpy(out.rgb.data() + r * row, bottom_up_.data() + (height_ - 1 - r) * row, row);
}

// ---- start-up check ----------------------------------------------------------------------------------

std::string check_rendering(GlContext& gl, int width, int height) {
  gl.make_current();
  struct Release {
    GlContext& gl;
    ~Release() { gl.release(); }
  } release{gl};
  if (auto gl_string = gl_get_string()) {
    const unsigned char* v = gl_string(kGlVersion);
    // MuJoCo 2.2's renderer needs OpenGL 1.5 with framebuffer objects; it exits the process otherwise.
    if (!v || std::atof(reinterpret_cast<const char*>(v)) < 1.5)
      throw RenderError(std::string("OpenGL 1.5 or newer is needed, the context offers ") +
                        (v ? reinterpret_cast<const char*>(v) : "no version string"));
  }
  ModelPtr m = compile_model(check_model(width, height), "render check");
  DataPtr d = make_data(m.get());
  mj_forward(m.get(), d.get());
  std::string description = gl.description();
  Image img;
  {
    CameraRig rig(m.get(), d.get(), {"check"}, width, height);
    rig.render(0, img);
  }
  // The box fills the middle of the view: it must come out red.
  const std::uint8_t* c = img.pixel(height / 2, width / 2);
  if (c[0] < 64 || c[0] < c[1] + 40 || c[0] < c[2] + 40)
    throw RenderError("the render check came out wrong (centre pixel " + std::to_string(c[0]) + "," +
                      std::to_string(c[1]) + "," + std::to_string(c[2]) + ", expected red) on " +
                      description);
  return description;
}

}  // namespace dh::sim
