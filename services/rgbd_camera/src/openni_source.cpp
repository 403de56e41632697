#include "dh/rgbd_camera/openni_source.hpp"

#include <OpenNI.h>

#include <cstdlib>
#include <thread>

#include "dh/rgbd_camera/frame_convert.hpp"

namespace dh::camera {

namespace {

std::string extended_error() {
  std::string e = openni::OpenNI::getExtendedError();
  while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
  while (!e.empty() && (e.front() == '\t' || e.front() == ' ')) e.erase(e.begin());
  return e.empty() ? "no detail from OpenNI2" : e;
}

const char* format_name(openni::PixelFormat f) {
  switch (f) {
    case openni::PIXEL_FORMAT_DEPTH_1_MM:
      return "depth 1 mm";
    case openni::PIXEL_FORMAT_DEPTH_100_UM:
      return "depth 100 um";
    case openni::PIXEL_FORMAT_SHIFT_9_2:
      return "depth shift 9.2";
    case openni::PIXEL_FORMAT_SHIFT_9_3:
      return "depth shift 9.3";
    case openni::PIXEL_FORMAT_RGB888:
      return "RGB888";
    case openni::PIXEL_FORMAT_YUV422:
      return "YUV422";
    case openni::PIXEL_FORMAT_GRAY8:
      return "GRAY8";
    case openni::PIXEL_FORMAT_GRAY16:
      return "GRAY16";
    case openni::PIXEL_FORMAT_JPEG:
      return "JPEG";
    case openni::PIXEL_FORMAT_YUYV:
      return "YUYV";
  }
  return "unknown";
}

std::string mode_text(const openni::VideoMode& m) {
  return std::to_string(m.getResolutionX()) + "x" + std::to_string(m.getResolutionY()) + "@" +
         std::to_string(m.getFps()) + " " + format_name(m.getPixelFormat());
}

bool depth_format(openni::PixelFormat f) {
  return f == openni::PIXEL_FORMAT_DEPTH_1_MM || f == openni::PIXEL_FORMAT_DEPTH_100_UM;
}

bool colour_format(openni::PixelFormat f) { return f == openni::PIXEL_FORMAT_RGB888; }

}  // namespace

std::vector<std::string> list_devices() {
  if (openni::OpenNI::initialize() != openni::STATUS_OK)
    throw SourceError("OpenNI2 cannot start: " + extended_error() +
                      " (is libopenni2-0 installed with its drivers?)");
  openni::Array<openni::DeviceInfo> found;
  openni::OpenNI::enumerateDevices(&found);
  std::vector<std::string> out;
  for (int i = 0; i < found.getSize(); ++i)
    out.push_back(std::string(found[i].getUri()) + "  " + found[i].getVendor() + " " + found[i].getName());
  openni::OpenNI::shutdown();
  return out;
}

struct OpenNiSource::Impl {
  SourceOptions opt;
  std::string uri, vendor, name;
  bool initialized = false;
  openni::Device device;
  openni::VideoStream depth, colour;
  bool registered = false;

  ~Impl() {
    bool started = false;
    for (auto* s : {&depth, &colour})
      if (s->isValid()) {
        s->stop();
        started = true;
      }
    // A driver's threads may still be finishing a frame after stop() returns (OpenNI2's test device's
    // do, for up to a frame period): unloading the driver under them would crash the process at exit.
    if (started) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (auto* s : {&depth, &colour})
      if (s->isValid()) s->destroy();
    if (device.isValid()) device.close();
    if (initialized) openni::OpenNI::shutdown();
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw SourceError("camera " + (uri.empty() ? std::string("(the first OpenNI2 device)") : uri) + ": " +
                      what);
  }

  /// Picks the mode a stream runs in: the asked size (and rate), in a format the wire takes; the
  /// current mode when nothing is asked and its format will do.
  void choose_mode(openni::VideoStream& s, const char* sensor, bool (*usable)(openni::PixelFormat)) {
    const openni::VideoMode current = s.getVideoMode();
    const bool asked = opt.width > 0 || opt.fps > 0;
    const int w = opt.width > 0 ? opt.width : current.getResolutionX();
    const int h = opt.height > 0 ? opt.height : current.getResolutionY();
    const auto fits = [&](const openni::VideoMode& m) {
      return usable(m.getPixelFormat()) && m.getResolutionX() == w && m.getResolutionY() == h &&
             (opt.fps <= 0 || m.getFps() == opt.fps);
    };
    if (!asked && usable(current.getPixelFormat())) return;
    const auto& modes = s.getSensorInfo().getSupportedVideoModes();
    std::string listed;
    for (int i = 0; i < modes.getSize(); ++i) {
      listed += (i ? ", " : "") + mode_text(modes[i]);
      if (fits(modes[i])) {
        if (fits(current)) return;
        if (s.setVideoMode(modes[i]) != openni::STATUS_OK)
          fail(std::string("its ") + sensor + " stream refused the mode " + mode_text(modes[i]) + ": " +
               extended_error());
        return;
      }
    }
    if (fits(current)) return;
    fail(std::string("no ") + sensor + " mode of " + std::to_string(w) + "x" + std::to_string(h) +
         (opt.fps > 0 ? "@" + std::to_string(opt.fps) : std::string()) +
         " in a format this publisher takes (" +
         (usable == &depth_format ? "depth 1 mm or 100 um" : "RGB888") + "); the sensor offers: " +
         (listed.empty() ? "no list" : listed) + " (choose one with --width, --height, --fps)");
  }

  /// The next frame of `s` after what it holds now.
  openni::VideoFrameRef next(openni::VideoStream& s, const char* sensor, bool drain) {
    openni::VideoStream* one[] = {&s};
    int ready = -1;
    openni::VideoFrameRef f;
    if (drain)
      while (openni::OpenNI::waitForAnyStream(one, 1, &ready, 0) == openni::STATUS_OK) s.readFrame(&f);
    if (openni::OpenNI::waitForAnyStream(one, 1, &ready, static_cast<int>(opt.timeout.count())) !=
        openni::STATUS_OK)
      fail(std::string("no ") + sensor + " frame within " + std::to_string(opt.timeout.count()) +
           " ms (the device stopped sending, or was unplugged)");
    if (s.readFrame(&f) != openni::STATUS_OK || !f.isValid())
      fail(std::string("the ") + sensor + " frame could not be read: " + extended_error());
    return f;
  }
};

OpenNiSource::OpenNiSource(const SourceOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.opt = options;
  m.uri = options.device;
  if ((options.width > 0) != (options.height > 0)) m.fail("give --width and --height together");
  if (openni::OpenNI::initialize() != openni::STATUS_OK)
    m.fail("OpenNI2 cannot start: " + extended_error() + " (is libopenni2-0 installed with its drivers?)");
  m.initialized = true;
  if (m.device.open(options.device.empty() ? openni::ANY_DEVICE : options.device.c_str()) !=
      openni::STATUS_OK) {
    openni::Array<openni::DeviceInfo> found;
    openni::OpenNI::enumerateDevices(&found);
    std::string uris;
    for (int i = 0; i < found.getSize(); ++i) uris += (i ? ", " : "") + std::string(found[i].getUri());
    m.fail("cannot be opened: " + extended_error() + "; OpenNI2 sees " +
           (uris.empty() ? std::string("no device") : "these devices: " + uris) +
           " (is it plugged in, and is its OpenNI2 driver in OpenNI2's drivers folder?)");
  }
  const openni::DeviceInfo& info = m.device.getDeviceInfo();
  m.uri = info.getUri();
  m.vendor = info.getVendor();
  m.name = info.getName();
  if (!m.device.hasSensor(openni::SENSOR_DEPTH) ||
      m.depth.create(m.device, openni::SENSOR_DEPTH) != openni::STATUS_OK)
    m.fail("has no depth stream: " + extended_error());
  if (!m.device.hasSensor(openni::SENSOR_COLOR) ||
      m.colour.create(m.device, openni::SENSOR_COLOR) != openni::STATUS_OK)
    m.fail("has no colour stream: " + extended_error());
  m.choose_mode(m.depth, "depth", &depth_format);
  m.choose_mode(m.colour, "colour", &colour_format);
  const auto dm = m.depth.getVideoMode(), cm = m.colour.getVideoMode();
  if (dm.getResolutionX() != cm.getResolutionX() || dm.getResolutionY() != cm.getResolutionY())
    m.fail("its depth (" + mode_text(dm) + ") and colour (" + mode_text(cm) +
           ") differ in size; choose a size both offer with --width and --height");
  // OpenNI devices may mirror their images by default; the wire's pixels are the camera's own.
  for (auto* s : {&m.depth, &m.colour})
    if (s->isPropertySupported(openni::STREAM_PROPERTY_MIRRORING)) s->setMirroringEnabled(false);
  if (options.registration) {
    if (!m.device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR))
      m.fail(
          "cannot register depth to colour (its driver does not offer it); perception needs depth in the "
          "colour camera's pixels. --registration none publishes depth as the device gives it, right only if "
          "its depth already is in the colour camera's frame");
    if (m.device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) != openni::STATUS_OK)
      m.fail("refused to register depth to colour: " + extended_error());
    m.registered = true;
  }
  // Frames taken together where the device can; where it cannot, grab() pairs them by time.
  m.device.setDepthColorSyncEnabled(true);
  if (m.depth.start() != openni::STATUS_OK) m.fail("its depth stream does not start: " + extended_error());
  if (m.colour.start() != openni::STATUS_OK) m.fail("its colour stream does not start: " + extended_error());
}

OpenNiSource::~OpenNiSource() = default;

LiveFrame OpenNiSource::grab() {
  Impl& m = *impl_;
  openni::VideoFrameRef d = m.next(m.depth, "depth", true);
  openni::VideoFrameRef c = m.next(m.colour, "colour", true);
  // Timestamps are the device's, in microseconds; a frame period apart at most, or the older is read again.
  const int fps = std::max(1, m.depth.getVideoMode().getFps());
  const auto period_us = static_cast<long long>(1e6 / fps);
  for (int tries = 0; tries < 4; ++tries) {
    const auto dt = static_cast<long long>(d.getTimestamp()) - static_cast<long long>(c.getTimestamp());
    if (std::llabs(dt) <= period_us) break;
    if (dt < 0)
      d = m.next(m.depth, "depth", false);
    else
      c = m.next(m.colour, "colour", false);
  }
  if (d.getVideoMode().getPixelFormat() != m.depth.getVideoMode().getPixelFormat() ||
      c.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888)
    m.fail("sent a frame in another format than its stream's mode (depth " +
           std::string(format_name(d.getVideoMode().getPixelFormat())) + ", colour " +
           format_name(c.getVideoMode().getPixelFormat()) + ")");
  if (d.getWidth() != c.getWidth() || d.getHeight() != c.getHeight())
    m.fail("sent depth of " + std::to_string(d.getWidth()) + "x" + std::to_string(d.getHeight()) +
           " with colour of " + std::to_string(c.getWidth()) + "x" + std::to_string(c.getHeight()));
  LiveFrame f;
  f.index = d.getFrameIndex();
  f.width = d.getWidth();
  f.height = d.getHeight();
  const DepthUnit unit = d.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM
                             ? DepthUnit::HundredMicrometre
                             : DepthUnit::Millimetre;
  f.depth_mm = depth_mm(d.getData(), d.getWidth(), d.getHeight(), d.getStrideInBytes(), unit);
  f.rgb = rgb_rows(c.getData(), c.getWidth(), c.getHeight(), c.getStrideInBytes());
  return f;
}

const std::string& OpenNiSource::uri() const { return impl_->uri; }

std::string OpenNiSource::describe() const {
  const Impl& m = *impl_;
  return m.vendor + " " + m.name + " (" + m.uri + "): depth " + mode_text(m.depth.getVideoMode()) +
         ", colour " + mode_text(m.colour.getVideoMode()) +
         (m.registered ? ", depth registered to colour by the device" : ", depth as the device gives it");
}

int OpenNiSource::width() const { return impl_->colour.getVideoMode().getResolutionX(); }
int OpenNiSource::height() const { return impl_->colour.getVideoMode().getResolutionY(); }
double OpenNiSource::hfov() const { return impl_->colour.getHorizontalFieldOfView(); }
double OpenNiSource::vfov() const { return impl_->colour.getVerticalFieldOfView(); }

}  // namespace dh::camera
