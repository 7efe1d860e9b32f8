#include "dco/ipc/publisher.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <optional>
#include <system_error>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <lcm/lcm-cpp.hpp>

#include "dco/core/error.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "lcm_sender.hpp"
#include "lcm_setup.hpp"

namespace dco::ipc {
namespace {

// LCM takes a channel as a std::string: built once, since a name past the short-string buffer
// ("DCO_DEPTH_PREVIEW") would allocate at every message.
const std::string kDepthChannel{channel::kDepth}, kDepthPreviewChannel{channel::kDepthPreview},
    kStatsChannel{channel::kStats}, kStatusChannel{channel::kStatus}, kRawChannel{channel::kRaw},
    kLogChannel{channel::kLog};

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

// LCM strings end at their first NUL, though their encoded size counts every byte: the bytes
// after it would go out unwritten. A NUL in a device string or a log line becomes '?'.
std::string lcm_string(std::string_view text) {
  std::string s(text);
  std::replace(s.begin(), s.end(), '\0', '?');
  return s;
}

std::int64_t as_lcm(std::uint64_t v) {
  return static_cast<std::int64_t>(v);  // LCM has no unsigned types; the bits travel unchanged
}

// Nearest valid depth in a block: for occlusion the nearest surface is the one that matters.
std::int16_t block_depth_mm(ImageView<const float> depth, int x0, int y0, int factor) {
  float nearest = std::numeric_limits<float>::infinity();
  for (int y = y0; y < std::min(y0 + factor, depth.height); ++y) {
    const float* row = depth.row(y);
    for (int x = x0; x < std::min(x0 + factor, depth.width); ++x)
      if (row[x] > 0.0f && row[x] < nearest) nearest = row[x];
  }
  if (!std::isfinite(nearest)) return 0;
  // Clamped before rounding: a far but finite depth (a tiny disparity) overflows a long in mm.
  return static_cast<std::int16_t>(std::lround(std::clamp(nearest * 1000.0f, 1.0f, 32767.0f)));
}

// Whether a UDP socket can be connected to the udpm URL's group (LCM's own first check); true
// for other providers and for what it cannot read, which LCM then judges.
bool udpm_route_ready(std::string url) {
  if (url.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    url = env != nullptr && *env != '\0' ? env : "udpm://239.255.76.67:7667";
  }
  constexpr std::string_view kUdpm = "udpm://";
  if (!url.starts_with(kUdpm)) return true;
  const std::string address = url.substr(kUdpm.size(), url.find('?') - kUdpm.size());
  const std::size_t colon = address.rfind(':');
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(
      colon == std::string::npos ? 7667 : std::atoi(address.c_str() + colon + 1)));
  if (inet_pton(AF_INET, address.substr(0, colon).c_str(), &to.sin_addr) != 1) return true;
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return true;
  const bool ok = connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0;
  close(fd);
  return ok;
}

// Messages waiting for LCM at most: a second of DCO_DEPTH at 60 fps, with its previews, stats and
// log lines. A backlog beyond that is a network that does not take them: the oldest give way.
constexpr std::size_t kQueuedMessages = 64;
// How long a DCO_RAW pair may wait for LCM before its recorder counts it as not sent.
constexpr std::chrono::milliseconds kRawSendWait{2000};

// Room for the largest small message from the start: a preview of the configured size, or a few
// kilobytes of log line or status.
std::size_t small_message_bytes(const PublisherOptions& o) {
  const auto preview = static_cast<std::size_t>(std::max(o.preview_max_width, 1)) *
                       static_cast<std::size_t>(std::max(o.preview_max_height, 1)) * 2;
  return std::max<std::size_t>(preview + 256, 4096);
}

}  // namespace

void check_lcm_url(std::string_view url) {
  if (url.empty()) return;  // LCM's default: $LCM_DEFAULT_URL, else udpm
  const std::size_t end = url.find("://");
  const std::string_view provider = url.substr(0, end);
  if (end == std::string_view::npos || std::find(std::begin(kLcmProviders), std::end(kLcmProviders),
                                                 provider) == std::end(kLcmProviders))
    throw Error(fmt::format("lcm.url '{}': not PROVIDER://... with a provider LCM has ({})", url,
                            fmt::join(kLcmProviders, ", ")));
}

int preview_factor(int width, int height, int max_width, int max_height) {
  // One whole factor for both axes keeps the preview's pixels square.
  return std::max({1, (width + max_width - 1) / std::max(1, max_width),
                   (height + max_height - 1) / std::max(1, max_height)});
}

void make_depth_preview(ImageView<const float> depth, int factor, ::dco::depth_preview_t& out) {
  if (factor < 1) throw Error(fmt::format("depth preview: factor {} out of range", factor));
  out.source_width = depth.width;
  out.source_height = depth.height;
  out.width = (depth.width + factor - 1) / factor;
  out.height = (depth.height + factor - 1) / factor;
  out.num_pixels = out.width * out.height;
  out.depth_mm.resize(static_cast<std::size_t>(out.num_pixels));
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      out.depth_mm[static_cast<std::size_t>(y * out.width + x)] =
          block_depth_mm(depth, x * factor, y * factor, factor);
}

DepthPublisher::DepthPublisher(RingWriter& ring, const PublisherOptions& options)
    : ring_(ring), options_(options), stats_since_ns_(monotonic_ns()) {
  if (options.preview_hz < 0 || options.preview_max_width < 1 || options.preview_max_height < 1)
    throw Error(fmt::format("publisher: preview rate {} Hz or size {}x{} out of range",
                            options.preview_hz, options.preview_max_width,
                            options.preview_max_height));
  check_lcm_url(options.lcm_url);
  sender_ = std::make_unique<detail::LcmSender>(kQueuedMessages, small_message_bytes(options));
  retry_lcm(options.lcm_setup_wait);
}

bool DepthPublisher::retry_lcm(std::chrono::milliseconds wait) {
  if (lcm_ready_) return true;
  // One that has not ended by now waits for an answer that will not come (a server gone without
  // a word): left behind, its thread ends whenever its socket does.
  if (setup_ && setup_->age() > options_.lcm_setup_patience &&
      detail::LcmSetup::running() < kMostLcmSetups) {
    setup_.reset();
    setup_running_ = false;
  }
  if (!setup_) {
    // LCM prints a dozen lines of advice at every failed udpm setup: after the first, a retry
    // waits until a route to the group is there.
    if (tried_lcm_ && !udpm_route_ready(options_.lcm_url)) return false;
    tried_lcm_ = true;
    try {
      setup_ = std::make_unique<detail::LcmSetup>(options_.lcm_url);
    } catch (const std::system_error&) {
      setup_unstarted_ = true;  // out of threads: the next retry tries again
      return false;
    }
    setup_unstarted_ = false;
    setup_running_ = true;
  }
  std::optional<std::unique_ptr<lcm::LCM>> lcm = setup_->result(wait);
  if (!lcm) return false;
  setup_.reset();
  setup_running_ = false;
  if (!*lcm) return false;
  sender_->set_lcm(std::move(*lcm));
  lcm_ready_ = true;
  return true;
}

int DepthPublisher::lcm_setups_running() {
  return detail::LcmSetup::running();
}

std::string DepthPublisher::lcm_problem() const {
  if (lcm_ready_) return {};
  const std::string url = options_.lcm_url.empty() ? "the default URL" : options_.lcm_url;
  if (setup_unstarted_) return fmt::format("LCM's set-up with '{}' found no thread to run on", url);
  if (setup_running_)
    return fmt::format("LCM's set-up with '{}' has not ended (for tcpq, does the server answer?)",
                       url);
  return fmt::format("LCM cannot be set up with '{}' (for udpm, is there a multicast route?)", url);
}

lcm::LCM& DepthPublisher::lcm() {
  lcm::LCM* const lcm = sender_->lcm();
  if (lcm == nullptr) throw Error("publisher: " + lcm_problem());
  return *lcm;
}

DepthPublisher::~DepthPublisher() = default;

bool DepthPublisher::flush(std::chrono::milliseconds wait) {
  return sender_->flush(wait);
}

std::uint64_t DepthPublisher::send_failures() const {
  return sender_->failures();
}

const char* DepthPublisher::last_failed_channel() const {
  return sender_->last_failed_channel();
}

bool DepthPublisher::raw_can_go() const {
  return lcm_ready_ && !sender_->blocked();
}

void DepthPublisher::set_preview_hz(double hz) {
  if (!(hz >= 0)) throw Error(fmt::format("publisher: preview rate {} Hz out of range", hz));
  options_.preview_hz = hz;
}

RingWriter::Slot DepthPublisher::begin_write() {
  RingWriter::Slot slot = ring_.begin_write();
  open_slot_ = slot.index;
  open_depth_ = slot.depth;
  return slot;
}

std::uint64_t DepthPublisher::publish(const FrameMeta& meta) {
  const std::uint64_t index = ring_.publish(meta);
  announce(index, open_slot_, meta, open_depth_);
  return index;
}

std::uint64_t DepthPublisher::write(ImageView<const float> depth,
                                    ImageView<const std::uint8_t> image, const FrameMeta& meta) {
  const std::uint64_t index = ring_.write(depth, image, meta);
  announce(index, ring_.current_slot(), meta, depth);
  return index;
}

template <class Message>
void DepthPublisher::send(const std::string& channel, const Message& message) {
  if (!lcm_ready_) {
    sender_->count_failure(channel);  // not even encoded: nothing could send it
    return;
  }
  const int size = message.getEncodedSize();
  encoded_.resize(static_cast<std::size_t>(std::max(size, 0)));  // grows once, then reused
  if (size >= 0 && message.encode(encoded_.data(), 0, size) == size)
    sender_->post(channel, encoded_.data(), static_cast<std::size_t>(size));
  else
    sender_->count_failure(channel);
}

void DepthPublisher::announce(std::uint64_t publish_index, std::uint32_t slot,
                              const FrameMeta& meta, ImageView<const float> depth) {
  dco::depth_frame_t m;
  m.session_id = as_lcm(ring_.session_id());
  m.slot = static_cast<std::int32_t>(slot);
  m.publish_index = as_lcm(publish_index);
  m.frame_seq = as_lcm(meta.frame_seq);
  m.capture_ns = meta.capture_ns;
  m.publish_ns = monotonic_ns();
  m.width = ring_.options().width;
  m.height = ring_.options().height;
  send(kDepthChannel, m);
  if (options_.preview_hz > 0) {
    // A rate so low that its period passes int64 nanoseconds (292 years) means one preview.
    const double period = 1e9 / options_.preview_hz;
    const std::int64_t period_ns = period < 9e18 ? static_cast<std::int64_t>(period)
                                                 : std::numeric_limits<std::int64_t>::max();
    // By capture time, so a replay previews the frames the headset did. A stamp that went back
    // (a camera's clock fault) starts the pacing afresh rather than silence the previews until
    // the clock has caught up with the one that went ahead.
    const std::int64_t since = meta.capture_ns - last_preview_capture_ns_;
    if (!preview_sent_ || since >= period_ns || since < 0) send_preview(publish_index, meta, depth);
  }
}

void DepthPublisher::send_preview(std::uint64_t publish_index, const FrameMeta& meta,
                                  ImageView<const float> depth) {
  // Kept between previews: its pixels are allocated once.
  dco::depth_preview_t& m = preview_;
  m.session_id = as_lcm(ring_.session_id());
  m.publish_index = as_lcm(publish_index);
  m.frame_seq = as_lcm(meta.frame_seq);
  m.capture_ns = meta.capture_ns;
  make_depth_preview(depth,
                     preview_factor(depth.width, depth.height, options_.preview_max_width,
                                    options_.preview_max_height),
                     m);
  send(kDepthPreviewChannel, m);
  preview_sent_ = true;
  last_preview_capture_ns_ = meta.capture_ns;
  ++previews_sent_;
}

void DepthPublisher::publish_stats(const pipeline::runtime::RuntimeStats& stats,
                                   std::int64_t now_ns) {
  dco::pipeline_stats_t m;
  m.utime_ns = now_ns;
  m.interval_s = static_cast<double>(now_ns - stats_since_ns_) * 1e-9;
  // A runtime restart resets its counters; rates then count from zero.
  const long pushed_before = stats.pushed >= stats_pushed_ ? stats_pushed_ : 0;
  const long published_before = stats.published >= stats_published_ ? stats_published_ : 0;
  m.fps_in =
      m.interval_s > 0 ? static_cast<double>(stats.pushed - pushed_before) / m.interval_s : 0.0;
  m.fps_out = m.interval_s > 0
                  ? static_cast<double>(stats.published - published_before) / m.interval_s
                  : 0.0;
  m.pushed = stats.pushed;
  m.dropped = stats.dropped;
  m.published = stats.published;
  m.latency_p50_ms = stats.latency.p50_ms;
  m.latency_p99_ms = stats.latency.p99_ms;
  m.stereo_p50_ms = stats.stereo.p50_ms;
  m.stereo_p99_ms = stats.stereo.p99_ms;
  m.contour_p50_ms = stats.contour.p50_ms;
  m.contour_p99_ms = stats.contour.p99_ms;
  m.densify_p50_ms = stats.densify.p50_ms;
  m.densify_p99_ms = stats.densify.p99_ms;
  m.entry_high_water = static_cast<std::int32_t>(stats.entry_high_water);
  m.stereo_queue_high_water = static_cast<std::int32_t>(stats.stereo_queue_high_water);
  m.densify_queue_high_water = static_cast<std::int32_t>(stats.densify_queue_high_water);
  const stereo::CameraCorrection& c = stats.camera_correction;
  m.right_channels = static_cast<std::int8_t>(c.levels.count);
  for (std::size_t i = 0; i < c.levels.channels.size(); ++i) {
    m.right_gain[i] = c.levels.channels[i].gain;
    m.right_level_offset[i] = c.levels.channels[i].offset;
  }
  m.right_row_offset = c.row_offset;
  m.right_roll_deg = c.roll * 180.0 / std::numbers::pi;
  m.lens_falloff = c.falloff;
  send(kStatsChannel, m);
  stats_since_ns_ = now_ns;
  stats_pushed_ = stats.pushed;
  stats_published_ = stats.published;
}

void DepthPublisher::publish_status(const DeviceStatus& status, std::int64_t now_ns) {
  dco::device_status_t m;
  m.utime_ns = now_ns;
  m.state = static_cast<std::int8_t>(status.state);
  m.device = lcm_string(status.device);
  m.serial = lcm_string(status.serial);
  m.firmware = lcm_string(status.firmware);
  m.usb_speed_mbps = status.usb_speed_mbps;
  m.error = lcm_string(status.error);
  m.counter_count = static_cast<std::int32_t>(status.counters.size());
  for (const auto& [name, value] : status.counters) {
    m.counter_names.push_back(lcm_string(name));
    m.counter_values.push_back(static_cast<std::int64_t>(value));
  }
  send(kStatusChannel, m);
}

bool DepthPublisher::publish_raw(const ::dco::raw_stereo_t& message) {
  std::lock_guard lock(raw_mutex_);
  if (!lcm_ready_) {
    sender_->count_failure(kRawChannel);
    throw Error(fmt::format("publisher: {} not sent: {}", channel::kRaw, lcm_problem()));
  }
  std::vector<std::uint8_t>* bytes = sender_->acquire_large(kRawSendWait);
  if (bytes == nullptr) {
    sender_->count_failure(kRawChannel);
    throw Error(
        fmt::format("publisher: {} not sent: LCM's network holds a send (for more than {} ms)",
                    channel::kRaw, kRawSendWait.count()));
  }
  const int size = message.getEncodedSize();
  bytes->resize(static_cast<std::size_t>(std::max(size, 0)));  // grows once, then reused
  if (size < 0 || message.encode(bytes->data(), 0, size) != size) {
    sender_->count_failure(kRawChannel);
    throw Error(fmt::format("publisher: {} does not encode", channel::kRaw));
  }
  switch (sender_->send_large(kRawChannel, static_cast<std::size_t>(size), kRawSendWait)) {
    case detail::LcmSender::LargeOutcome::kSent:
      return true;
    case detail::LcmSender::LargeOutcome::kStillSending:
      return false;
    case detail::LcmSender::LargeOutcome::kFailed:
      throw Error(fmt::format("publisher: LCM publish on {} failed", channel::kRaw));
    case detail::LcmSender::LargeOutcome::kTimedOut:
      throw Error(
          fmt::format("publisher: LCM did not start sending {} within {} ms: the "
                      "network holds the pair before it",
                      channel::kRaw, kRawSendWait.count()));
  }
  return false;  // not reached: every outcome returns above
}

void DepthPublisher::log(LogLevel level, std::string_view source, std::string_view text,
                         std::int64_t now_ns) {
  dco::log_event_t m;
  m.utime_ns = now_ns;
  m.level = static_cast<std::int8_t>(level);
  m.source = lcm_string(source);
  m.text = lcm_string(text);
  send(kLogChannel, m);
}

}  // namespace dco::ipc
