#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/depth_preview_t.hpp"
#include "dco/ipc/ring_writer.hpp"
#include "dco/pipeline/runtime/depth_runtime.hpp"
#include "dco/raw_stereo_t.hpp"

namespace lcm {
class LCM;
}

namespace dco::ipc {
namespace detail {
class LcmSender;
class LcmSetup;
}  // namespace detail

struct PublisherOptions {
  // LCM provider URL; empty = LCM's default (LCM_DEFAULT_URL, else udpm multicast).
  std::string lcm_url;
  double preview_hz = 2.0;  // DCO_DEPTH_PREVIEW rate by capture time; 0 = never
  // The preview is the depth map shrunk by one whole factor until it fits this size.
  int preview_max_width = 80;
  int preview_max_height = 60;
  // LCM's set-up: how long the constructor waits for it, and after how long one that has not
  // ended (a tcpq server that accepted and went away without a word) is left behind for a fresh
  // one. At most kMostLcmSetups are left running at once, each a thread and a socket.
  std::chrono::milliseconds lcm_setup_wait{2000};
  std::chrono::milliseconds lcm_setup_patience{30000};
};
inline constexpr int kMostLcmSetups = 4;

struct DeviceStatus {
  enum class State : std::int8_t { kDisconnected = 0, kStarting = 1, kStreaming = 2, kError = 3 };
  State state = State::kDisconnected;
  std::string device, serial, firmware;
  int usb_speed_mbps = 0;
  std::string error;
  std::vector<std::pair<std::string, std::uint64_t>> counters;
};

enum class LogLevel : std::int8_t { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// The providers LCM knows (1.3: lcm_create's table).
inline constexpr std::string_view kLcmProviders[] = {"udpm", "file", "memq", "tcpq", "mpudpm"};
// Throws dco::Error when `url` is neither empty (LCM's default) nor PROVIDER://... with one of
// kLcmProviders: a mistyped provider is a configuration error, where a udpm URL that cannot be
// set up now (no multicast route yet) is the network's state.
void check_lcm_url(std::string_view url);

// DCO_DEPTH_PREVIEW's pixels: the nearest depth in each factor x factor block in millimetres (0 =
// unknown, 32767 = that far or farther); sets the sizes, num_pixels and depth_mm of `out`. A
// replay computes the same to compare with what a headset recorded. Throws dco::Error when
// factor < 1.
void make_depth_preview(ImageView<const float> depth, int factor, ::dco::depth_preview_t& out);
// The smallest whole factor that shrinks width x height into max_width x max_height.
int preview_factor(int width, int height, int max_width, int max_height);

// The daemon's publishing side: frames go into the shared-memory ring first and are then announced
// on DCO_DEPTH (a descriptor naming session, slot and publish index, never pixels), with a small
// preview on DCO_DEPTH_PREVIEW at a few Hz; runtime statistics, device status and log events go
// to DCO_STATS, DCO_STATUS and DCO_LOG. Not thread-safe: one thread publishes, except publish_raw,
// which any one other thread may call meanwhile.
class DepthPublisher {
 public:
  // Throws dco::Error when the URL names no LCM provider (check_lcm_url). An LCM that cannot be
  // set up now (udpm without a multicast route: a headset booted without a network), or whose
  // set-up has not ended within lcm_setup_wait (a tcpq server that accepts and never answers),
  // leaves the publisher without LCM: depth still reaches the ring, every message counts as a
  // send failure, and retry_lcm() tries again.
  DepthPublisher(RingWriter& ring, const PublisherOptions& options);
  DepthPublisher(const DepthPublisher&) = delete;
  DepthPublisher& operator=(const DepthPublisher&) = delete;
  ~DepthPublisher();

  // LCM is best effort beside the ring: messages are encoded and queued, and a thread of the
  // publisher's own sends them, so a send the network holds up (a tcpq peer that stopped
  // reading, a slow link) delays LCM only. A message LCM cannot send, or one that gives way in a
  // full queue to a newer one, is counted in send_failures() and the call goes on, so depth
  // keeps reaching the ring's readers. Only publish_raw throws, for its recorder's own
  // accounting. The destructor sends what waits (for up to a second, unless a flush() ran out).
  //
  // Zero copy: fill the slot begin_write() returns, then publish() it. publish stamps the slot
  // (RingWriter::publish), announces it and sends a preview when one is due; it returns the
  // publish index.
  RingWriter::Slot begin_write();
  std::uint64_t publish(const FrameMeta& meta);
  // Copies depth (and the image, exactly when the ring holds one) into the next slot, then
  // publishes it. Throws dco::Error on a size mismatch.
  std::uint64_t write(ImageView<const float> depth, ImageView<const std::uint8_t> image,
                      const FrameMeta& meta);

  // DCO_STATS from the runtime's counters and histograms; frame rates over the interval since the
  // previous call (or since construction). now_ns: CLOCK_MONOTONIC.
  void publish_stats(const pipeline::runtime::RuntimeStats& stats, std::int64_t now_ns);
  void publish_status(const DeviceStatus& status, std::int64_t now_ns);
  void log(LogLevel level, std::string_view source, std::string_view text, std::int64_t now_ns);
  // DCO_RAW: a recorded raw pair (the daemon's raw recorder builds it), sent in its turn among
  // the other messages; returns true once LCM has sent it, false when LCM is still sending it
  // after two seconds (the network holds it: it goes out if the network takes it, and counts in
  // send_failures() if the send fails). Throws dco::Error when LCM is not set up, refuses it, or
  // has not started it within two seconds (the network holds the pair before it).
  bool publish_raw(const ::dco::raw_stereo_t& message);
  bool lcm_ready() const { return lcm_ready_; }
  // Whether a DCO_RAW pair could go out now: LCM is set up and its network is not holding a
  // send past publish_raw's wait. A raw recorder need not compress pairs that cannot go out.
  bool raw_can_go() const;

  // Changes the DCO_DEPTH_PREVIEW rate (a configuration reload); throws dco::Error when < 0.
  void set_preview_hz(double hz);

  std::uint64_t previews_sent() const { return previews_sent_; }
  // Messages LCM could not send or that gave way in a full queue (DCO_RAW's included), and the
  // channel of the last one.
  std::uint64_t send_failures() const;
  const char* last_failed_channel() const;
  // Waits until every queued message has been handed to LCM; false when `wait` ran out first.
  bool flush(std::chrono::milliseconds wait);
  // Sets LCM up when it is not yet; true when it is (now or before). The set-up runs on a thread
  // of its own: this waits up to `wait` for it, and a set-up still running then is looked at
  // again by the next call instead of starting another, until lcm_setup_patience has passed.
  // Any one thread may call it while another publishes.
  bool retry_lcm(std::chrono::milliseconds wait = std::chrono::milliseconds(0));
  // Whether a set-up retry_lcm() started is still running.
  bool lcm_setup_running() const { return setup_running_; }
  // Set-ups in this process that have not ended, those left behind included.
  static int lcm_setups_running();
  // Empty while LCM is set up, else why it is not.
  std::string lcm_problem() const;
  // Throws dco::Error while LCM is not set up.
  lcm::LCM& lcm();

 private:
  // `depth`: the published frame, for the preview.
  void announce(std::uint64_t publish_index, std::uint32_t slot, const FrameMeta& meta,
                ImageView<const float> depth);
  void send_preview(std::uint64_t publish_index, const FrameMeta& meta,
                    ImageView<const float> depth);
  // Encodes into encoded_ and queues it; counted as a failure when LCM is not set up or the
  // message does not encode to its own size (a string with a NUL, which LCM's encoder stops at).
  template <class Message>
  void send(const std::string& channel, const Message& message);

  RingWriter& ring_;
  PublisherOptions options_;
  std::unique_ptr<detail::LcmSender> sender_;
  std::atomic<bool> lcm_ready_{false};
  bool tried_lcm_ = false;
  std::unique_ptr<detail::LcmSetup> setup_;   // the set-up running; null when none
  std::atomic<bool> setup_running_{false};    // setup_ != null, for other threads
  std::atomic<bool> setup_unstarted_{false};  // the last try could not start its thread
  std::mutex raw_mutex_;                      // publish_raw's callers
  std::vector<std::uint8_t> encoded_;
  ::dco::depth_preview_t preview_;
  std::uint32_t open_slot_ = 0;
  ImageView<const float> open_depth_;  // the slot begin_write() opened
  bool preview_sent_ = false;
  std::int64_t last_preview_capture_ns_ = 0;
  std::uint64_t previews_sent_ = 0;
  std::int64_t stats_since_ns_ = 0;
  long stats_pushed_ = 0, stats_published_ = 0;
};

}  // namespace dco::ipc
