// libcamera://LEFT_ID,RIGHT_ID (two mono cameras) or libcamera://ID?layout=sbs (one sensor whose
// frames hold left|right side by side), through libcamera 0.0.3's C++ API.
//
// libcamera completes requests on its own thread. That thread only pairs completed requests by
// sensor timestamp and keeps the newest pair; the source's delivery thread copies the luma of that
// pair into two images of its own, hands the buffers straight back to the cameras and then calls
// the sink. The copy is one sequential read per frame: camera buffers are often uncached on
// embedded boards, and rectification reads its input in a scattered order.

#include <linux/dma-buf.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <libcamera/libcamera.h>

#include "../src/sources.hpp"
#include "dco/core/error.hpp"
#include "dco/core/thread_name.hpp"
#include "dco/drivers/capture_gaps.hpp"
#include "frame_pairer.hpp"

namespace dco::drivers {
namespace {

namespace lc = libcamera;

// CLOCK_MONOTONIC, the clock libcamera stamps frames with.
std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

// A camera keeps capturing only while it has queued requests; at most four per camera are held
// here at once (two waiting for a partner, one in the ready pair, one being copied).
constexpr unsigned kMinBuffers = 6;
// A request's cookie: the device in the high bits, the buffer below.
constexpr unsigned kCookieDeviceShift = 16;
constexpr std::size_t kMaxPending = 2;
// This many frames in a row without a partner means the two cameras do not run at one rate.
constexpr int kMaxUnpairedRun = 120;

std::string errno_text(int err) {
  return std::strerror(err < 0 ? -err : err);
}

struct Params {
  std::vector<std::string> ids;  // left, right; one id for side by side
  bool sbs = false;
  int width = 0, height = 0;  // per eye; 0 = the calibration's size
  double fps = 0;             // 0 = the cameras' own rate
  std::filesystem::path calib;
};

// Everything the URI alone decides, checked before any camera is touched.
Params read_params(SourceUri& uri) {
  const std::string where = fmt::format("source '{}'", uri.text());
  Params p;
  p.width = uri.integer("width", 0, 16, 8192);
  p.height = uri.integer("height", 0, 16, 8192);
  p.fps = uri.fps(0, "the cameras' own rate");
  const auto layout = uri.value("layout");
  const auto calib = uri.value("calib");
  uri.finish();

  const std::string& path = uri.path();
  for (std::size_t begin = 0;;) {
    const auto comma = path.find(',', begin);
    p.ids.push_back(path.substr(begin, comma == std::string::npos ? comma : comma - begin));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  const bool empty_id =
      std::any_of(p.ids.begin(), p.ids.end(), [](const std::string& id) { return id.empty(); });
  if (empty_id || p.ids.size() > 2)
    throw Error(where + ": expected libcamera://LEFT_ID,RIGHT_ID or libcamera://ID?layout=sbs");
  if (layout && *layout != "pair" && *layout != "sbs")
    throw Error(fmt::format("{}: layout={} must be pair or sbs", where, *layout));
  p.sbs = layout && *layout == "sbs";
  if (p.sbs && p.ids.size() != 1)
    throw Error(
        fmt::format("{}: layout=sbs takes exactly one camera id, got {}", where, p.ids.size()));
  if (!p.sbs && p.ids.size() != 2)
    throw Error(where + (layout ? ": layout=pair needs two camera ids (LEFT_ID,RIGHT_ID)"
                                : ": one camera id needs layout=sbs (or give LEFT_ID,RIGHT_ID)"));
  if (p.ids.size() == 2 && p.ids[0] == p.ids[1])
    throw Error(fmt::format("{}: left and right are the same camera '{}'", where, p.ids[0]));
  if (!calib || calib->empty())
    throw Error(where + ": calib=FILE is required (libcamera cameras carry no calibration)");
  p.calib = *calib;
  return p;
}

// Loads the calibration and settles the per-eye size: the calibration's, which explicit width and
// height must match.
StereoCalibration load_checked_calibration(Params& p, const std::string& uri) {
  const std::string where = fmt::format("source '{}'", uri);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p.calib, ec))
    throw Error(fmt::format("{}: calib={}: no such file", where, p.calib.string()));
  StereoCalibration calib = load_calibration(p.calib);
  const CameraIntrinsics& cam = calib.left;
  if (cam.width == 0 && cam.height == 0) {
    // Rectified files without a size leave it to the images.
    if (p.width == 0 || p.height == 0)
      throw Error(fmt::format("{}: {} has no image size; give width= and height=", where,
                              p.calib.string()));
    calib.take_size_if_unknown(p.width, p.height);
    return calib;
  }
  const int width = p.width ? p.width : cam.width;
  const int height = p.height ? p.height : cam.height;
  if (width != cam.width || height != cam.height)
    throw Error(fmt::format("{}: frames of {}x{} per eye, but the calibration is for {}x{}", where,
                            width, height, cam.width, cam.height));
  p.width = width;
  p.height = height;
  return calib;
}

// Only one CameraManager may exist in a process; every source shares the one alive.
std::shared_ptr<lc::CameraManager> camera_manager() {
  static std::mutex mutex;
  static std::weak_ptr<lc::CameraManager> shared;
  std::lock_guard lock(mutex);
  if (auto manager = shared.lock()) return manager;
  auto manager = std::make_shared<lc::CameraManager>();
  if (const int ret = manager->start(); ret < 0)
    throw Error(fmt::format("libcamera: no camera found (the camera manager did not start: {})",
                            errno_text(ret)));
  shared = manager;
  return manager;
}

// Where the luma of a pixel lies in plane 0 of a format dco can use.
struct LumaLayout {
  lc::PixelFormat format;
  int bytes_per_pixel;  // 1: a plane of luma (grey or planar YUV); 2: packed 4:2:2
  int offset;           // byte of the luma within a pixel
};

// In order of preference: grey, then planar YUV (its Y plane is a grey image), then packed YUV.
const std::array<LumaLayout, 17> kLumaLayouts{{{lc::formats::R8, 1, 0},
                                               {lc::formats::NV12, 1, 0},
                                               {lc::formats::NV21, 1, 0},
                                               {lc::formats::YUV420, 1, 0},
                                               {lc::formats::YVU420, 1, 0},
                                               {lc::formats::NV16, 1, 0},
                                               {lc::formats::NV61, 1, 0},
                                               {lc::formats::YUV422, 1, 0},
                                               {lc::formats::YVU422, 1, 0},
                                               {lc::formats::NV24, 1, 0},
                                               {lc::formats::NV42, 1, 0},
                                               {lc::formats::YUV444, 1, 0},
                                               {lc::formats::YVU444, 1, 0},
                                               {lc::formats::YUYV, 2, 0},
                                               {lc::formats::YVYU, 2, 0},
                                               {lc::formats::UYVY, 2, 1},
                                               {lc::formats::VYUY, 2, 1}}};

// Index into kLumaLayouts, or its size for a format without usable luma.
std::size_t luma_rank(const lc::PixelFormat& format) {
  for (std::size_t i = 0; i < kLumaLayouts.size(); ++i)
    if (kLumaLayouts[i].format == format) return i;
  return kLumaLayouts.size();
}

std::string size_list(const lc::StreamFormats& formats, const lc::PixelFormat& format) {
  const std::vector<lc::Size> sizes = formats.sizes(format);
  if (sizes.empty()) return formats.range(format).toString();
  std::string out;
  for (std::size_t i = 0; i < sizes.size() && i < 12; ++i)
    out += (i ? ", " : "") + sizes[i].toString();
  if (sizes.size() > 12) out += ", ...";
  return out;
}

// Tells the exporter that the CPU reads a buffer, so caches are kept coherent with the device.
// Exporters without the ioctl need nothing.
void sync_for_cpu(int fd, std::uint64_t flags) {
  dma_buf_sync sync{};
  sync.flags = flags;
  while (::ioctl(fd, DMA_BUF_IOCTL_SYNC, &sync) < 0 && (errno == EINTR || errno == EAGAIN)) {
  }
}

// One camera's buffers mapped into memory: plane 0 of buffer i, for the request with cookie i.
struct Mapping {
  void* base = MAP_FAILED;
  std::size_t length = 0;
  const std::uint8_t* plane = nullptr;
  int fd = -1;
};

using Pairer = FramePairer<lc::Request*>;

// One opened camera: acquired, configured, its buffers allocated and mapped and one request per
// buffer, all made once and reused from start to start.
struct Device {
  std::string id;
  std::shared_ptr<lc::Camera> camera;
  bool acquired = false;
  std::unique_ptr<lc::CameraConfiguration> config;
  lc::Stream* stream = nullptr;
  LumaLayout luma{};
  unsigned stride = 0;
  std::unique_ptr<lc::FrameBufferAllocator> allocator;
  std::vector<Mapping> mappings;
  std::vector<std::unique_ptr<lc::Request>> requests;

  Device() = default;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;
  ~Device() {
    if (camera) {
      camera->requestCompleted.disconnect(this);
      camera->disconnected.disconnect(this);
    }
    requests.clear();
    for (const Mapping& m : mappings)
      if (m.base != MAP_FAILED) ::munmap(m.base, m.length);
    allocator.reset();
    if (acquired) camera->release();
  }
};

class LibcameraSource final : public FrameSource {
 public:
  explicit LibcameraSource(SourceUri& uri) {
    Params p = read_params(uri);
    info_.uri = uri.text();
    calibration_ = load_checked_calibration(p, uri.text());
    sbs_ = p.sbs;
    fps_ = p.fps;
    width_ = p.width;
    height_ = p.height;

    manager_ = camera_manager();
    const auto cameras = manager_->cameras();
    if (cameras.empty()) throw Error("libcamera: no camera found");
    for (std::size_t i = 0; i < p.ids.size(); ++i) {
      devices_.push_back(std::make_unique<Device>());
      open(*devices_.back(), i, p.ids[i], cameras);
    }
    if (fps_ > 0) {
      // Both cameras run at the asked rate: a frame duration limit of exactly one period.
      const auto period_us = static_cast<std::int64_t>(std::llround(1e6 / fps_));
      for (const auto& d : devices_) {
        const auto limits = d->camera->controls().find(&lc::controls::FrameDurationLimits);
        if (limits == d->camera->controls().end())
          throw Error(fmt::format(
              "libcamera: camera '{}' cannot set its frame rate; leave out fps= to use its own",
              d->id));
        // A camera clamps a duration outside its range without a word, and the pairing
        // tolerance below would then be for a rate it does not run at.
        const lc::ControlInfo& range = limits->second;
        if (range.min().type() == lc::ControlTypeInteger64 && !range.min().isArray() &&
            range.max().type() == lc::ControlTypeInteger64 && !range.max().isArray()) {
          const std::int64_t shortest = range.min().get<std::int64_t>();
          const std::int64_t longest = range.max().get<std::int64_t>();
          if (shortest > 0 && longest >= shortest && (period_us < shortest || period_us > longest))
            throw Error(
                fmt::format("libcamera: camera '{}' runs at {:.4g}..{:.4g} fps; fps={} is "
                            "outside",
                            d->id, 1e6 / static_cast<double>(longest),
                            1e6 / static_cast<double>(shortest), fps_));
        }
      }
      start_controls_.set(lc::controls::FrameDurationLimits, {period_us, period_us});
      pairer_.set_period(static_cast<std::int64_t>(std::llround(1e9 / fps_)));
    }
    left_.resize(width_, height_);
    right_.resize(width_, height_);

    info_.width = width_;
    info_.height = height_;
    info_.channels = 1;
    info_.fps = fps_;
    const std::string rate = fps_ > 0 ? fmt::format("{} fps", fps_) : std::string("camera rate");
    const Device& first = *devices_.front();
    info_.description =
        sbs_ ? fmt::format("libcamera {} side by side {}x{} per eye {} @ {}", first.id, width_,
                           height_, first.luma.format.toString(), rate)
             : fmt::format("libcamera {} + {} {}x{} {} @ {}", first.id, devices_.back()->id, width_,
                           height_, first.luma.format.toString(), rate);
  }

  ~LibcameraSource() override { stop(); }

  const SourceInfo& info() const override { return info_; }
  const StereoCalibration& calibration() const override { return calibration_; }

  SourceStatus status() const override {
    SourceStatus s;
    s.device = info_.description;
    for (const auto& d : devices_) s.serial += (s.serial.empty() ? "" : ",") + d->id;
    std::lock_guard lock(mutex_);
    s.state = !disconnected_.empty()                       ? SourceStatus::State::kDisconnected
              : !error_.empty()                            ? SourceStatus::State::kError
              : running_ && seq_ > delivered_before_start_ ? SourceStatus::State::kStreaming
                                                           : SourceStatus::State::kStarting;
    s.error = error_;
    s.counters = {{"frames", captured_},
                  {"delivered", seq_},
                  {"delivery_drops", pairer_.counters().overtaken},
                  {"unpaired_frames", pairer_.counters().unpaired},
                  {"error_frames", failed_}};
    return s;
  }

  void start(FrameSink& sink) override {
    if (thread_.joinable()) throw Error(info_.uri + ": source already started");
    {
      std::lock_guard lock(mutex_);
      if (!disconnected_.empty()) throw Error(disconnected_);
      error_.clear();
      pairer_.clear();
      delivered_before_start_ = seq_;
      quit_ = false;
    }
    std::size_t started = 0;
    try {
      // The delivery thread first, waiting for completions: a thread that cannot be created
      // (the unit's TasksMax) then fails the start before any camera runs.
      thread_ = std::thread([this, &sink] {
        name_this_thread("dco-libcamera");
        deliver(sink);
      });
      for (; started < devices_.size(); ++started) {
        Device& d = *devices_[started];
        if (const int ret = d.camera->start(fps_ > 0 ? &start_controls_ : nullptr); ret < 0)
          throw Error(
              fmt::format("libcamera: cannot start camera '{}': {}", d.id, errno_text(ret)));
      }
      std::lock_guard lock(mutex_);
      running_ = true;
      for (auto& d : devices_)
        for (auto& r : d->requests) {
          r->reuse(lc::Request::ReuseBuffers);
          if (const int ret = d->camera->queueRequest(r.get()); ret < 0)
            throw Error(fmt::format("libcamera: cannot queue a request on camera '{}': {}", d->id,
                                    errno_text(ret)));
        }
    } catch (...) {
      {
        std::lock_guard lock(mutex_);
        running_ = false;
        quit_ = true;
      }
      wake_.notify_all();
      if (thread_.joinable()) thread_.join();
      thread_ = {};
      for (std::size_t i = 0; i < started; ++i) devices_[i]->camera->stop();
      throw;
    }
  }

  void stop() override {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mutex_);
      running_ = false;  // from here on no request is queued again
      quit_ = true;
    }
    wake_.notify_all();
    thread_.join();
    thread_ = {};
    // Cancels the requests in flight; their completions find running_ false and are left idle.
    for (auto& d : devices_) d->camera->stop();
    std::lock_guard lock(mutex_);
    pairer_.clear();
  }

 private:
  void open(Device& d, std::size_t index, const std::string& id,
            const std::vector<std::shared_ptr<lc::Camera>>& all) {
    d.id = id;
    d.camera = manager_->get(id);
    if (!d.camera) {
      std::string ids;
      for (const auto& c : all) ids += (ids.empty() ? "" : ", ") + c->id();
      throw Error(fmt::format("libcamera: no camera '{}' (cameras: {})", id, ids));
    }
    if (const int ret = d.camera->acquire(); ret < 0)
      throw Error(
          fmt::format("libcamera: camera '{}' is busy ({}); another process or source holds it", id,
                      errno_text(ret)));
    d.acquired = true;

    choose_format(d);
    lc::StreamConfiguration& cfg = d.config->at(0);
    const lc::Size asked(static_cast<unsigned>(sbs_ ? 2 * width_ : width_),
                         static_cast<unsigned>(height_));
    cfg.size = asked;
    cfg.bufferCount = std::max(cfg.bufferCount, kMinBuffers);
    const lc::StreamFormats offered = cfg.formats();
    const lc::CameraConfiguration::Status status = d.config->validate();
    if (status == lc::CameraConfiguration::Invalid)
      throw Error(fmt::format("libcamera: camera '{}' rejects {} {}", id, asked.toString(),
                              d.luma.format.toString()));
    if (cfg.pixelFormat != d.luma.format || cfg.size != asked)
      throw Error(
          fmt::format("libcamera: camera '{}' cannot deliver {} {} (it offers {} {}; sizes: {})",
                      id, asked.toString(), d.luma.format.toString(), cfg.size.toString(),
                      cfg.pixelFormat.toString(), size_list(offered, d.luma.format)));
    if (const int ret = d.camera->configure(d.config.get()); ret < 0)
      throw Error(fmt::format("libcamera: cannot configure camera '{}': {}", id, errno_text(ret)));
    d.stream = cfg.stream();
    d.stride = cfg.stride;

    d.allocator = std::make_unique<lc::FrameBufferAllocator>(d.camera);
    if (const int ret = d.allocator->allocate(d.stream); ret < 0)
      throw Error(fmt::format("libcamera: cannot allocate buffers on camera '{}': {}", id,
                              errno_text(ret)));
    const auto& buffers = d.allocator->buffers(d.stream);
    const std::size_t row_bytes =
        static_cast<std::size_t>(cfg.size.width) * static_cast<std::size_t>(d.luma.bytes_per_pixel);
    const std::size_t needed =
        static_cast<std::size_t>(d.stride) * (cfg.size.height - 1) + row_bytes;
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      const lc::FrameBuffer::Plane& plane = buffers[i]->planes().front();
      if (d.stride < row_bytes || plane.length < needed)
        throw Error(fmt::format(
            "libcamera: camera '{}' gives {}-byte buffers with stride {}; {} {} needs {}", id,
            plane.length, d.stride, cfg.size.toString(), d.luma.format.toString(), needed));
      Mapping m;
      m.fd = plane.fd.get();
      const std::size_t offset =
          plane.offset == lc::FrameBuffer::Plane::kInvalidOffset ? 0 : plane.offset;
      const std::size_t map_offset = offset / page * page;
      m.length = plane.length + (offset - map_offset);
      m.base =
          ::mmap(nullptr, m.length, PROT_READ, MAP_SHARED, m.fd, static_cast<off_t>(map_offset));
      if (m.base == MAP_FAILED)
        throw Error(fmt::format("libcamera: cannot map a buffer of camera '{}': {}", id,
                                errno_text(errno)));
      m.plane = static_cast<const std::uint8_t*>(m.base) + (offset - map_offset);
      d.mappings.push_back(m);

      std::unique_ptr<lc::Request> request =
          d.camera->createRequest(index << kCookieDeviceShift | i);
      if (!request)
        throw Error(fmt::format("libcamera: cannot create a request on camera '{}'", id));
      if (const int ret = request->addBuffer(d.stream, buffers[i].get()); ret < 0)
        throw Error(fmt::format("libcamera: cannot attach a buffer on camera '{}': {}", id,
                                errno_text(ret)));
      d.requests.push_back(std::move(request));
    }

    Device* device = &d;
    d.camera->requestCompleted.connect(device,
                                       [this, device](lc::Request* r) { completed(*device, r); });
    d.camera->disconnected.connect(device, [this, device] { disconnected(*device); });
  }

  // Picks the best luma format of any role: an 8-bit grey stream (often Raw on mono sensors)
  // before the luma of YUV (Viewfinder on most pipelines).
  void choose_format(Device& d) {
    std::size_t best = kLumaLayouts.size();
    std::vector<std::string> offered;
    for (const lc::StreamRole role : {lc::StreamRole::Viewfinder, lc::StreamRole::Raw}) {
      std::unique_ptr<lc::CameraConfiguration> config = d.camera->generateConfiguration({role});
      if (!config || config->empty()) continue;
      std::size_t role_best = kLumaLayouts.size();
      for (const lc::PixelFormat& f : config->at(0).formats().pixelformats()) {
        const std::string name = f.toString();
        if (std::find(offered.begin(), offered.end(), name) == offered.end())
          offered.push_back(name);
        role_best = std::min(role_best, luma_rank(f));
      }
      if (role_best >= best) continue;
      best = role_best;
      d.luma = kLumaLayouts[best];
      config->at(0).pixelFormat = d.luma.format;
      d.config = std::move(config);
    }
    if (!d.config) {
      std::string list;
      for (const std::string& name : offered) list += (list.empty() ? "" : ", ") + name;
      throw Error(
          fmt::format("libcamera: camera '{}' offers no 8-bit grey or YUV format (it offers: {})",
                      d.id, list.empty() ? std::string("none") : list));
    }
  }

  // On libcamera's thread. Pairs and keeps the newest pair; everything else goes straight back.
  void completed(Device& d, lc::Request* r) {
    std::lock_guard lock(mutex_);
    if (!running_ || r->status() == lc::Request::RequestCancelled) return;
    const lc::FrameBuffer* buffer = r->findBuffer(d.stream);
    if (!buffer || buffer->metadata().status != lc::FrameMetadata::FrameSuccess) {
      ++failed_;
      requeue(r);
      return;
    }
    ++captured_;
    const auto sensor_ns = r->metadata().get(lc::controls::SensorTimestamp);
    Pairer::Frame frame{
        r, sensor_ns ? *sensor_ns : static_cast<std::int64_t>(buffer->metadata().timestamp)};
    const auto release = [this](lc::Request* dropped) { requeue(dropped); };
    if (sbs_) {
      // One sensor needs no partner: a driver that stamps nothing gets the time it arrived.
      if (frame.ns <= 0) frame.ns = monotonic_ns();
      pairer_.add_single(frame, release);
      wake_.notify_all();
      return;
    }
    const int eye = device_of(r);
    if (eye == 0 && fps_ <= 0) {
      // Without fps= the tolerance follows the left camera: the frame duration it reports or
      // else the measured time between its frames.
      const auto duration_us = r->metadata().get(lc::controls::FrameDuration);
      if (duration_us && *duration_us > 0)
        pairer_.set_period(*duration_us * 1000);
      else
        pairer_.measure(buffer->metadata().sequence, frame.ns);
    }
    if (pairer_.add(eye, frame, release)) wake_.notify_all();
    if (pairer_.counters().untimed > 0 && error_.empty()) {
      error_ = fmt::format(
          "libcamera: camera '{}' gives its frames no timestamp; two cameras cannot be paired "
          "without one (a side-by-side sensor can: layout=sbs)",
          d.id);
      wake_.notify_all();
    }
    if (pairer_.unpaired_run() >= kMaxUnpairedRun && error_.empty()) {
      error_ = fmt::format(
          "libcamera: cameras '{}' and '{}' delivered {} frames in a row without a partner within "
          "{:.1f} ms; do they run at the same frame rate?",
          devices_[0]->id, devices_[1]->id, pairer_.unpaired_run(), pairer_.period() / 2e6);
      wake_.notify_all();
    }
  }

  static int device_of(const lc::Request* r) {
    return static_cast<int>(r->cookie() >> kCookieDeviceShift);
  }
  static std::size_t buffer_of(const lc::Request* r) {
    return static_cast<std::size_t>(r->cookie() & ((1u << kCookieDeviceShift) - 1));
  }

  // Caller holds mutex_.
  void requeue(lc::Request* r) {
    if (!running_ || !r) return;
    r->reuse(lc::Request::ReuseBuffers);
    // Fails only while the camera stops; the request then stays idle until the next start.
    devices_[static_cast<std::size_t>(device_of(r))]->camera->queueRequest(r);
  }

  void disconnected(Device& d) {
    std::lock_guard lock(mutex_);
    disconnected_ = fmt::format(
        "libcamera: camera '{}' disconnected (after {} pairs delivered; {} frames unpaired, {} "
        "pairs overtaken, {} frames failed)",
        d.id, seq_, pairer_.counters().unpaired, pairer_.counters().overtaken, failed_);
    if (error_.empty()) error_ = disconnected_;
    wake_.notify_all();
  }

  void copy_luma(const lc::Request* r, int x0, Image<std::uint8_t>& out) const {
    const Device& d = *devices_[static_cast<std::size_t>(device_of(r))];
    const std::uint8_t* base = d.mappings[buffer_of(r)].plane +
                               static_cast<std::ptrdiff_t>(x0) * d.luma.bytes_per_pixel +
                               d.luma.offset;
    for (int y = 0; y < height_; ++y) {
      const std::uint8_t* src = base + static_cast<std::ptrdiff_t>(y) * d.stride;
      std::uint8_t* dst = out.row(y);
      if (d.luma.bytes_per_pixel == 1) {
        std::memcpy(dst, src, static_cast<std::size_t>(width_));
      } else {
        for (int x = 0; x < width_; ++x) dst[x] = src[2 * x];
      }
    }
  }

  int fd_of(const lc::Request* r) const {
    return devices_[static_cast<std::size_t>(device_of(r))]->mappings[buffer_of(r)].fd;
  }

  void deliver(FrameSink& sink) {
    StereoFrame frame;
    for (;;) {
      Pairer::Pair pair;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return quit_ || !error_.empty() || pairer_.has_pair(); });
        if (quit_) return;
        if (!error_.empty()) {
          const std::string message = error_;
          lock.unlock();
          sink.on_error(message);
          return;
        }
        pair = *pairer_.take();
      }
      // Side by side, both eyes come from the left frame's buffer.
      const lc::Request* left = pair[0].handle;
      const lc::Request* right = sbs_ ? left : pair[1].handle;
      sync_for_cpu(fd_of(left), DMA_BUF_SYNC_START | DMA_BUF_SYNC_READ);
      if (!sbs_) sync_for_cpu(fd_of(right), DMA_BUF_SYNC_START | DMA_BUF_SYNC_READ);
      copy_luma(left, 0, left_);
      copy_luma(right, sbs_ ? width_ : 0, right_);
      sync_for_cpu(fd_of(left), DMA_BUF_SYNC_END | DMA_BUF_SYNC_READ);
      if (!sbs_) sync_for_cpu(fd_of(right), DMA_BUF_SYNC_END | DMA_BUF_SYNC_READ);
      {
        std::lock_guard lock(mutex_);
        requeue(pair[0].handle);
        requeue(pair[1].handle);  // null side by side
        frame.seq = seq_++;
      }
      frame.capture_ns = pair[0].ns;
      frame.follows_gap = gaps_.follows_gap(frame.capture_ns);
      frame.left = left_.cview();
      frame.right = right_.cview();
      try {
        sink.on_frame(frame);
      } catch (const std::exception& e) {
        sink.on_error(e.what());
        return;
      }
    }
  }

  // Destroyed last: cameras must go before the manager that owns them.
  std::shared_ptr<lc::CameraManager> manager_;
  SourceInfo info_;
  StereoCalibration calibration_;
  bool sbs_ = false;
  double fps_ = 0;
  int width_ = 0, height_ = 0;
  lc::ControlList start_controls_{lc::controls::controls};
  Image<std::uint8_t> left_, right_;
  CaptureGaps gaps_;  // the delivery thread's, over the pairs delivered

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  // Guarded by mutex_ (they are written on libcamera's thread).
  bool running_ = false;
  bool quit_ = false;
  Pairer pairer_{kMaxPending};
  std::string error_, disconnected_;
  std::uint64_t seq_ = 0;
  std::uint64_t delivered_before_start_ = 0;
  std::uint64_t captured_ = 0, failed_ = 0;

  // Destroyed before the state above, which their callbacks touch.
  std::vector<std::unique_ptr<Device>> devices_;
  std::thread thread_;
};

}  // namespace

std::unique_ptr<FrameSource> open_libcamera(SourceUri& uri) {
  return std::make_unique<LibcameraSource>(uri);
}

}  // namespace dco::drivers
