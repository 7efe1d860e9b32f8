// The LCM side of depth delivery, in one process over memq:// (nothing leaves the process): the
// checked decoder of every dco type, and the publisher's channels.

#include <signal.h>

#include <chrono>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>

#include "dco/client.h"
#include "dco/core/error.hpp"
#include "dco/ipc/lcm_messages.hpp"
#include "dco/ipc/publisher.hpp"
#include "ipc_test_support.hpp"
#include "lcm_samples.hpp"
#include "support/allocation_counter.hpp"
#include "support/stalled_tcpq_peer.hpp"

namespace dco::ipc::testing {
namespace {

template <class T>
std::vector<unsigned char> encode(const T& m) {
  std::vector<unsigned char> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return bytes;
}

template <class T>
std::string reject_reason(const std::vector<unsigned char>& bytes) {
  T out;
  std::string error;
  EXPECT_FALSE(decode_message(bytes.data(), bytes.size(), out, error));
  EXPECT_FALSE(error.empty());
  return error;
}

// Every truncation of a valid message is refused, and so is one byte too many.
template <class T>
void expect_round_trip_and_truncations_rejected(const T& m) {
  const std::vector<unsigned char> bytes = encode(m);
  T out;
  std::string error;
  ASSERT_TRUE(decode_message(bytes.data(), bytes.size(), out, error)) << error;
  EXPECT_EQ(encode(out), bytes);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    std::string e;
    T t;
    ASSERT_FALSE(decode_message(bytes.data(), n, t, e)) << n;
  }
  std::vector<unsigned char> longer = bytes;
  longer.push_back(0);
  EXPECT_NE(reject_reason<T>(longer).find("after the message"), std::string::npos);
}

void put_be32(std::vector<unsigned char>& b, std::size_t at, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = (u >> (24 - 8 * i)) & 0xff;
}

TEST(LcmMessages, EveryTypeRoundTripsAndTruncationsAreRejected) {
  expect_round_trip_and_truncations_rejected(sample_depth_frame());
  expect_round_trip_and_truncations_rejected(sample_preview());
  expect_round_trip_and_truncations_rejected(sample_stats());
  expect_round_trip_and_truncations_rejected(sample_status());
  expect_round_trip_and_truncations_rejected(sample_log());
  expect_round_trip_and_truncations_rejected(sample_raw());
}

TEST(LcmMessages, AnotherTypeIsRejectedByItsFingerprint) {
  const auto bytes = encode(sample_depth_frame());
  EXPECT_NE(reject_reason<dco::pipeline_stats_t>(bytes).find("fingerprint"), std::string::npos);
  EXPECT_NE(reject_reason<dco::depth_frame_t>({}).find("truncated"), std::string::npos);
}

TEST(LcmMessages, ForgedLengthsAreRejectedBeforeAnyAllocation) {
  // depth_preview_t: the element count follows 48 bytes of scalars and the fingerprint.
  constexpr std::size_t kCountAt = 8 + 48;
  auto bytes = encode(sample_preview());
  for (const std::int32_t n : {-1, std::numeric_limits<std::int32_t>::min(),
                               std::numeric_limits<std::int32_t>::max(), 1 << 20}) {
    put_be32(bytes, kCountAt, n);
    const std::string why = reject_reason<dco::depth_preview_t>(bytes);
    EXPECT_TRUE(why.find("count") != std::string::npos || why.find("exceeds") != std::string::npos)
        << why;
  }
  // log_event_t: the first string's length follows 9 bytes of scalars.
  constexpr std::size_t kStringAt = 8 + 9;
  const auto log = encode(sample_log());
  for (const std::int32_t n : {0, -1, std::numeric_limits<std::int32_t>::min(), 1 << 30}) {
    auto forged = log;
    put_be32(forged, kStringAt, n);
    EXPECT_NE(reject_reason<dco::log_event_t>(forged).find("string length"), std::string::npos);
  }
  auto unterminated = log;
  unterminated[kStringAt + 4 + sample_log().source.size()] = 'x';
  EXPECT_NE(reject_reason<dco::log_event_t>(unterminated).find("not terminated"),
            std::string::npos);
  auto inner_nul = log;
  inner_nul[kStringAt + 4 + 2] = 0;
  EXPECT_NE(reject_reason<dco::log_event_t>(inner_nul).find("NUL inside"), std::string::npos);
}

// Collects every message of the dco channels from the publisher's own memq:// instance.
class Collector {
 public:
  explicit Collector(lcm::LCM& lcm) { lcm.subscribeFunction(".*", &Collector::on_message, this); }
  std::vector<dco::depth_frame_t> depth;
  std::vector<dco::depth_preview_t> previews;
  std::vector<dco::pipeline_stats_t> stats;
  std::vector<dco::device_status_t> status;
  std::vector<dco::log_event_t> logs;

 private:
  template <class T>
  static void keep(const lcm::ReceiveBuffer* rbuf, std::vector<T>& into) {
    T m;
    std::string error;
    ASSERT_TRUE(decode_message(rbuf->data, rbuf->data_size, m, error)) << error;
    into.push_back(m);
  }
  static void on_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                         Collector* self) {
    if (channel == channel::kDepth) keep(rbuf, self->depth);
    if (channel == channel::kDepthPreview) keep(rbuf, self->previews);
    if (channel == channel::kStats) keep(rbuf, self->stats);
    if (channel == channel::kStatus) keep(rbuf, self->status);
    if (channel == channel::kLog) keep(rbuf, self->logs);
  }
};

void handle_all(DepthPublisher& pub) {
  ASSERT_TRUE(pub.flush(std::chrono::seconds(5)));
  lcm::LCM& lcm = pub.lcm();
  while (lcm.handleTimeout(0) > 0) {
  }
}

RingOptions ring_options(int w, int h) {
  RingOptions o;
  o.width = w;
  o.height = h;
  o.image_channels = 1;
  o.slot_count = 4;
  return o;
}

PublisherOptions memq() {
  PublisherOptions o;
  o.lcm_url = "memq://";
  return o;
}

TEST(Publisher, AnnouncesEveryFrameAfterItIsInTheRing) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(32, 16));
  DepthPublisher pub(ring, memq());
  Collector got(pub.lcm());
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string path = ring.path().string();
  o.path = path.c_str();
  dco_client* client = nullptr;
  ASSERT_EQ(dco_client_open(&o, &client), DCO_OK) << dco_client_last_error();

  Image<float> depth(32, 16);
  Image<std::uint8_t> image(32, 16);
  for (std::uint64_t seq = 1; seq <= 6; ++seq) {
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 32; ++x)
        depth.at(x, y) =
            pattern_depth(seq, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
    FrameMeta meta;
    meta.frame_seq = seq;
    meta.capture_ns = static_cast<std::int64_t>(seq) * 1000;
    if (seq % 2 != 0) {
      pub.write(depth.cview(), image.cview(), meta);
    } else {
      RingWriter::Slot slot = pub.begin_write();
      for (int y = 0; y < 16; ++y) std::memcpy(slot.depth.row(y), depth.row(y), 32 * sizeof(float));
      pub.publish(meta);
    }
    handle_all(pub);
    ASSERT_EQ(got.depth.size(), seq);
    const dco::depth_frame_t& d = got.depth.back();
    EXPECT_EQ(static_cast<std::uint64_t>(d.session_id), ring.session_id());
    EXPECT_EQ(static_cast<std::uint64_t>(d.publish_index), seq);
    EXPECT_EQ(static_cast<std::uint64_t>(d.frame_seq), seq);
    EXPECT_EQ(d.capture_ns, meta.capture_ns);
    EXPECT_EQ(d.width, 32);
    EXPECT_EQ(d.height, 16);
    std::vector<float> copy(32 * 16);
    dco_frame_buffer buf;
    dco_frame_buffer_init(&buf);
    buf.depth = copy.data();
    buf.depth_stride = 32 * sizeof(float);
    buf.depth_capacity = copy.size() * sizeof(float);
    dco_frame_info info;
    dco_frame_info_init(&info);
    ASSERT_EQ(dco_client_read_announced(client, static_cast<std::uint64_t>(d.session_id),
                                        static_cast<std::uint32_t>(d.slot),
                                        static_cast<std::uint64_t>(d.publish_index), &buf, &info),
              DCO_OK)
        << dco_client_last_error();
    EXPECT_EQ(info.frame_seq, seq);
    EXPECT_EQ(copy[5 * 32 + 7], pattern_depth(seq, 7, 5));
  }
  dco_client_close(client);
}

TEST(Publisher, PreviewIsSmallNearestDepthAndRateLimited) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(200, 90));
  PublisherOptions po = memq();
  po.preview_hz = 2.0;
  po.preview_max_width = 40;
  po.preview_max_height = 40;
  DepthPublisher pub(ring, po);
  Collector got(pub.lcm());
  Image<float> depth(200, 90);
  Image<std::uint8_t> image(200, 90);
  for (int y = 0; y < 90; ++y)
    for (int x = 0; x < 200; ++x) depth.at(x, y) = 2.0f;
  depth.at(6, 7) = 0.5f;                                     // block (1, 1) of factor 5
  depth.at(12, 0) = std::numeric_limits<float>::infinity();  // unknown pixels are skipped
  for (int y = 0; y < 5; ++y)
    for (int x = 195; x < 200; ++x) depth.at(x, y) = std::numeric_limits<float>::quiet_NaN();
  depth.at(199, 89) = 100.0f;
  // A far, finite depth (1e16 m: a disparity a hair above 0) is the farthest the preview holds.
  for (int y = 85; y < 90; ++y)
    for (int x = 0; x < 5; ++x) depth.at(x, y) = 1e16f;
  // 30 fps by capture time for one second: at 2 Hz that is a preview at 0 and 0.5 s.
  for (int i = 0; i < 30; ++i) {
    FrameMeta meta;
    meta.frame_seq = static_cast<std::uint64_t>(i);
    meta.capture_ns = i * 33'333'333LL;
    pub.write(depth.cview(), image.cview(), meta);
  }
  handle_all(pub);
  ASSERT_EQ(got.depth.size(), 30u);
  ASSERT_EQ(got.previews.size(), 2u);
  EXPECT_EQ(pub.previews_sent(), 2u);
  EXPECT_EQ(got.previews[1].frame_seq, 16);  // the first frame 0.5 s after frame 0
  const dco::depth_preview_t& p = got.previews[0];
  EXPECT_EQ(p.source_width, 200);
  EXPECT_EQ(p.source_height, 90);
  EXPECT_EQ(p.width, 40);  // factor 5
  EXPECT_EQ(p.height, 18);
  ASSERT_EQ(p.num_pixels, 40 * 18);
  EXPECT_EQ(p.depth_mm[0], 2000);
  EXPECT_EQ(p.depth_mm[1 * 40 + 1], 500);
  EXPECT_EQ(p.depth_mm[39], 0);               // nothing valid in that block
  EXPECT_EQ(p.depth_mm[17 * 40 + 39], 2000);  // nearest wins over the 100 m pixel
  EXPECT_EQ(p.depth_mm[17 * 40], 32767);
  EXPECT_EQ(static_cast<std::uint64_t>(p.session_id), ring.session_id());
}

// One frame stamped 5 s ahead (a camera's clock fault) among 30 fps frames: the previews go on
// at their rate rather than stop until the clock has caught up with it.
TEST(Publisher, AStampThatJumpsDoesNotSilenceThePreviews) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(40, 30));
  PublisherOptions po = memq();
  po.preview_hz = 2.0;
  DepthPublisher pub(ring, po);
  Collector got(pub.lcm());
  Image<float> depth(40, 30);
  Image<std::uint8_t> image(40, 30);
  depth.fill(2.0f);
  for (int i = 0; i < 90; ++i) {  // 3 s
    FrameMeta meta;
    meta.frame_seq = static_cast<std::uint64_t>(i);
    meta.capture_ns = i * 33'333'333LL + (i == 30 ? 5'000'000'000LL : 0);
    pub.write(depth.cview(), image.cview(), meta);
    ASSERT_TRUE(pub.flush(std::chrono::seconds(5)));  // 3 s of frames: more than the queue holds
  }
  handle_all(pub);
  // 0 and 0.5 s, the frame ahead, the one after it (the pacing afresh), then every 0.5 s.
  std::vector<std::int64_t> seqs;
  for (const auto& p : got.previews) seqs.push_back(p.frame_seq);
  EXPECT_EQ(seqs, (std::vector<std::int64_t>{0, 16, 30, 31, 47, 63, 79}));
}

// The publish path allocates nothing once warm, previews included (30 Hz: one every frame).
TEST(Publisher, WarmWritesDoNotAllocateEvenWithAPreviewEachFrame) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(200, 90));
  PublisherOptions po = memq();
  po.preview_hz = 30;
  DepthPublisher pub(ring, po);
  Image<float> depth(200, 90);
  depth.fill(2.0f);
  Image<std::uint8_t> image(200, 90);
  FrameMeta meta;
  for (int i = 0; i < 40; ++i) {
    meta.frame_seq = static_cast<std::uint64_t>(i);
    meta.capture_ns = i * 33'333'334LL;
    if (i == 10) dco::testing::start_counting_allocations();
    pub.write(depth.cview(), image.cview(), meta);
  }
  const dco::testing::AllocationCounts n = dco::testing::stop_counting_allocations();
  EXPECT_EQ(pub.previews_sent(), 40u);
  EXPECT_EQ(n.total(), 0) << n.new_calls << " new, " << n.aligned_alloc_calls << " aligned";
}

TEST(Publisher, NoPreviewAtZeroHz) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  PublisherOptions po = memq();
  po.preview_hz = 0;
  DepthPublisher pub(ring, po);
  Collector got(pub.lcm());
  Image<float> depth(8, 8);
  Image<std::uint8_t> image(8, 8);
  pub.write(depth.cview(), image.cview(), FrameMeta{});
  handle_all(pub);
  EXPECT_EQ(got.depth.size(), 1u);
  EXPECT_TRUE(got.previews.empty());
}

// A rate so low that its period passes what int64 nanoseconds hold still means the first frame's
// preview and no other (the period's conversion overflowed and previewed every frame).
TEST(Publisher, ATinyPreviewRateSendsOnlyTheFirstPreview) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  PublisherOptions po = memq();
  po.preview_hz = 1e-12;
  DepthPublisher pub(ring, po);
  Collector got(pub.lcm());
  Image<float> depth(8, 8);
  depth.fill(1.0f);
  Image<std::uint8_t> image(8, 8);
  for (int i = 1; i <= 5; ++i) {
    FrameMeta meta;
    meta.frame_seq = static_cast<std::uint64_t>(i);
    meta.capture_ns = i * 33'333'333LL;
    pub.write(depth.cview(), image.cview(), meta);
  }
  handle_all(pub);
  EXPECT_EQ(got.depth.size(), 5u);
  EXPECT_EQ(got.previews.size(), 1u);
}

TEST(Publisher, StatsStatusAndLog) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  DepthPublisher pub(ring, memq());
  Collector got(pub.lcm());
  pipeline::runtime::RuntimeStats s;
  s.pushed = 30;
  s.published = 25;
  s.dropped = 5;
  s.latency = {25, 41.5, 60.25, 42.0, 61.0};
  s.stereo = {25, 12.0, 15.0, 12.5, 16.0};
  s.contour = {25, 8.0, 9.5, 8.1, 9.9};
  s.densify = {25, 20.0, 30.0, 21.0, 31.0};
  s.entry_high_water = 1;
  s.stereo_queue_high_water = 2;
  s.densify_queue_high_water = 3;
  s.camera_correction.levels.count = 3;
  s.camera_correction.levels.channels = {{{0.97, 1.5}, {0.98, -0.5}, {1.01, 2.0}}};
  s.camera_correction.row_offset = 0.375;
  s.camera_correction.roll = -0.001;  // radians in the stage, degrees on the wire
  s.camera_correction.falloff = 0.125;
  // The first interval runs from construction, which the test does not control; the second is
  // exactly 2 s.
  const std::int64_t t0 = 1'000'000'000'000;
  pub.publish_stats(s, t0);
  s.pushed = 90;
  s.published = 75;
  pub.publish_stats(s, t0 + 2'000'000'000);
  pub.publish_status({DeviceStatus::State::kStreaming,
                      "INDEMIND",
                      "SN1",
                      "fw 2",
                      5000,
                      "",
                      {{"frames", 120}, {"lost_frames", 3}}},
                     t0);
  pub.log(LogLevel::kWarning, "camera", "frame 12 arrived late", t0);
  handle_all(pub);
  ASSERT_EQ(got.stats.size(), 2u);
  const dco::pipeline_stats_t& m = got.stats[1];
  EXPECT_DOUBLE_EQ(m.interval_s, 2.0);
  EXPECT_DOUBLE_EQ(m.fps_in, 30.0);
  EXPECT_DOUBLE_EQ(m.fps_out, 25.0);
  EXPECT_EQ(m.pushed, 90);
  EXPECT_EQ(m.dropped, 5);
  EXPECT_EQ(m.published, 75);
  EXPECT_DOUBLE_EQ(m.latency_p50_ms, 41.5);
  EXPECT_DOUBLE_EQ(m.latency_p99_ms, 60.25);
  EXPECT_DOUBLE_EQ(m.stereo_p99_ms, 15.0);
  EXPECT_DOUBLE_EQ(m.contour_p50_ms, 8.0);
  EXPECT_DOUBLE_EQ(m.densify_p99_ms, 30.0);
  EXPECT_EQ(m.densify_queue_high_water, 3);
  EXPECT_EQ(m.right_channels, 3);
  EXPECT_DOUBLE_EQ(m.right_gain[0], 0.97);
  EXPECT_DOUBLE_EQ(m.right_level_offset[1], -0.5);
  EXPECT_DOUBLE_EQ(m.right_gain[2], 1.01);
  EXPECT_DOUBLE_EQ(m.right_level_offset[2], 2.0);
  EXPECT_DOUBLE_EQ(m.right_row_offset, 0.375);
  EXPECT_NEAR(m.right_roll_deg, -0.0572958, 1e-7);
  EXPECT_DOUBLE_EQ(m.lens_falloff, 0.125);
  ASSERT_EQ(got.status.size(), 1u);
  EXPECT_EQ(got.status[0].state, std::int8_t{dco::device_status_t::STATE_STREAMING});
  ASSERT_EQ(got.status[0].counter_count, 2);
  EXPECT_EQ(got.status[0].counter_names[1], "lost_frames");
  EXPECT_EQ(got.status[0].counter_values[1], 3);
  EXPECT_EQ(got.status[0].serial, "SN1");
  EXPECT_EQ(got.status[0].usb_speed_mbps, 5000);
  ASSERT_EQ(got.logs.size(), 1u);
  EXPECT_EQ(got.logs[0].level, std::int8_t{dco::log_event_t::LEVEL_WARNING});
  EXPECT_EQ(got.logs[0].source, "camera");
  EXPECT_EQ(got.logs[0].text, "frame 12 arrived late");
}

// LCM's encoder stops a string at its first NUL while its size counts every byte: the message
// would carry unwritten bytes and fail every decoder. A NUL becomes '?' instead.
TEST(Publisher, StringsWithANulStillDecode) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  DepthPublisher pub(ring, memq());
  Collector got(pub.lcm());
  using namespace std::string_literals;
  pub.log(LogLevel::kError, "dcod"s, "path 'a\0b' refused"s, 1);
  pub.publish_status({DeviceStatus::State::kStreaming,
                      "INDEMIND",
                      "SN\0\0"s,
                      "fw",
                      480,
                      "",
                      {{"lost\0frames"s, 1}}},
                     1);
  handle_all(pub);
  ASSERT_EQ(got.logs.size(), 1u);
  EXPECT_EQ(got.logs[0].text, "path 'a?b' refused");
  ASSERT_EQ(got.status.size(), 1u);
  EXPECT_EQ(got.status[0].serial, "SN??");
  EXPECT_EQ(got.status[0].counter_names[0], "lost?frames");
  EXPECT_EQ(pub.send_failures(), 0u);
}

// A DCO_RAW pair that the network does not take holds up neither the frames nor their caller:
// every frame reaches the ring at once, the pair's caller is told after its wait, and the
// publisher goes away within its stop wait.
TEST(Publisher, ANetworkThatStopsTakingMessagesHoldsUpNeitherFramesNorTheCaller) {
  signal(SIGPIPE, SIG_IGN);  // as dcod: the peer's close fails the abandoned send, not the process
  dco::testing::StalledTcpqPeer peer;
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(64, 48));
  PublisherOptions po;
  po.lcm_url = peer.url();
  auto pub = std::make_unique<DepthPublisher>(ring, po);
  ASSERT_TRUE(pub->lcm_ready());
  dco::raw_stereo_t raw = sample_raw();
  raw.left.assign(64u << 20, 7);  // far more than both sockets' buffers hold
  raw.left_size = static_cast<std::int32_t>(raw.left.size());
  std::string raw_error;
  bool raw_sent = true;
  std::thread recorder([&] {
    try {
      raw_sent = pub->publish_raw(raw);
    } catch (const dco::Error& e) {
      raw_error = e.what();
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the pair is stuck by now
  Image<float> depth(64, 48);
  depth.fill(1.5f);
  Image<std::uint8_t> image(64, 48);
  double slowest_ms = 0;
  for (int i = 1; i <= 40; ++i) {
    FrameMeta meta;
    meta.frame_seq = static_cast<std::uint64_t>(i);
    meta.capture_ns = i * 33'333'333LL;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(pub->write(depth.cview(), image.cview(), meta), static_cast<std::uint64_t>(i));
    slowest_ms = std::max(
        slowest_ms,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  EXPECT_LT(slowest_ms, 100.0);
  EXPECT_EQ(ring.published(), 40u);
  recorder.join();
  // The pair is in its own send, which may yet finish: said so, not counted as a failure.
  EXPECT_FALSE(raw_sent);
  EXPECT_EQ(raw_error, "");
  EXPECT_EQ(pub->send_failures(), 0u);
  // The next pair is refused at once, and a recorder is told not to compress it: the first
  // still holds LCM.
  EXPECT_FALSE(pub->raw_can_go());
  EXPECT_TRUE(pub->lcm_ready());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(pub->publish_raw(sample_raw()), dco::Error);
  EXPECT_EQ(pub->send_failures(), 1u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500));
  const auto t1 = std::chrono::steady_clock::now();
  pub.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - t1, std::chrono::seconds(3));
}

// lcm_create for tcpq waits for the server's answer without a timeout: a server that accepts and
// hangs held the publisher's construction (dcod's start) and every retry for ever.
TEST(Publisher, ATcpqServerThatDoesNotAnswerHoldsUpNeitherTheStartNorTheFrames) {
  dco::testing::StalledTcpqPeer peer(dco::testing::StalledTcpqPeer::Handshake::kSilent);
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(32, 16));
  PublisherOptions po;
  po.lcm_url = peer.url();
  po.lcm_setup_wait = std::chrono::milliseconds(300);
  const auto t0 = std::chrono::steady_clock::now();
  DepthPublisher pub(ring, po);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_GE(took, po.lcm_setup_wait - std::chrono::milliseconds(20));
  EXPECT_LT(took, po.lcm_setup_wait + std::chrono::seconds(1));
  EXPECT_FALSE(pub.lcm_ready());
  EXPECT_TRUE(pub.lcm_setup_running());
  EXPECT_NE(pub.lcm_problem().find("has not ended"), std::string::npos) << pub.lcm_problem();
  EXPECT_THROW(pub.lcm(), dco::Error);

  Image<float> depth(32, 16);
  depth.fill(2.0f);
  Image<std::uint8_t> image(32, 16);
  FrameMeta meta;
  meta.frame_seq = 1;
  meta.capture_ns = 33'333'333;
  EXPECT_EQ(pub.write(depth.cview(), image.cview(), meta), 1u);
  EXPECT_EQ(ring.published(), 1u);
  const auto t1 = std::chrono::steady_clock::now();
  EXPECT_FALSE(pub.retry_lcm());
  EXPECT_LT(std::chrono::steady_clock::now() - t1, std::chrono::milliseconds(100));
  EXPECT_TRUE(pub.lcm_setup_running());

  // The server answers at last: the set-up under way ends, and LCM carries the next frame.
  peer.answer();
  EXPECT_TRUE(pub.retry_lcm(std::chrono::seconds(10)));
  EXPECT_TRUE(pub.lcm_ready());
  EXPECT_FALSE(pub.lcm_setup_running());
  EXPECT_EQ(pub.lcm_problem(), "");
  const std::uint64_t failures = pub.send_failures();
  meta.frame_seq = 2;
  meta.capture_ns = 66'666'666;
  EXPECT_EQ(pub.write(depth.cview(), image.cview(), meta), 2u);
  EXPECT_TRUE(pub.flush(std::chrono::seconds(5)));
  EXPECT_EQ(pub.send_failures(), failures);
}

// A publisher that goes away while its set-up still waits leaves it behind at once.
TEST(Publisher, ASetUpThatHangsDoesNotHoldUpTheEnd) {
  dco::testing::StalledTcpqPeer peer(dco::testing::StalledTcpqPeer::Handshake::kSilent);
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  PublisherOptions po;
  po.lcm_url = peer.url();
  po.lcm_setup_wait = std::chrono::milliseconds(100);
  auto pub = std::make_unique<DepthPublisher>(ring, po);
  ASSERT_TRUE(pub->lcm_setup_running());
  const auto t0 = std::chrono::steady_clock::now();
  pub.reset();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500));
}

// A set-up whose server went away without a word never ends: after lcm_setup_patience it is left
// behind and a fresh one tried, up to kMostLcmSetups threads (and sockets) at once.
TEST(Publisher, ASetUpLeftWithoutAnAnswerIsTriedAfreshUpToALimit) {
  // Those of the tests before end as their peers close.
  for (int i = 0; i < 500 && DepthPublisher::lcm_setups_running() > 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(DepthPublisher::lcm_setups_running(), 0);
  dco::testing::StalledTcpqPeer peer(dco::testing::StalledTcpqPeer::Handshake::kSilent);
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  PublisherOptions po;
  po.lcm_url = peer.url();
  po.lcm_setup_wait = std::chrono::milliseconds(50);
  po.lcm_setup_patience = std::chrono::milliseconds(150);
  DepthPublisher pub(ring, po);
  EXPECT_EQ(DepthPublisher::lcm_setups_running(), 1);
  EXPECT_FALSE(pub.retry_lcm());
  EXPECT_EQ(DepthPublisher::lcm_setups_running(), 1) << "within its patience";
  for (int i = 0; i < 2 * kMostLcmSetups; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(170));
    EXPECT_FALSE(pub.retry_lcm());
  }
  EXPECT_EQ(DepthPublisher::lcm_setups_running(), kMostLcmSetups);
  EXPECT_TRUE(pub.lcm_setup_running());
  EXPECT_NE(pub.lcm_problem().find("has not ended"), std::string::npos) << pub.lcm_problem();
}

TEST(Publisher, BadUrlIsAClearError) {
  TempDir dir;
  RingWriter ring(dir.path() / "depth.shm", ring_options(8, 8));
  PublisherOptions po;
  po.lcm_url = "nosuchprovider://";
  try {
    DepthPublisher pub(ring, po);
    FAIL() << "no error";
  } catch (const dco::Error& e) {
    EXPECT_NE(std::string(e.what()).find("nosuchprovider://"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dco::ipc::testing
