// One process, writer and client side by side: what a reader sees of a frame and when a view
// stops being valid.

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "dco/core/error.hpp"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

constexpr int kWidth = 96;
constexpr int kHeight = 40;

RingOptions small_ring(int slots = 4) {
  RingOptions o;
  o.width = kWidth;
  o.height = kHeight;
  o.image_channels = 1;
  o.slot_count = slots;
  return o;
}

client::Client connect(const std::filesystem::path& path) {
  client::Options o;
  o.path = path.string();
  return client::Client(o);
}

std::uint64_t view_checksum(const client::FrameView& v) {
  return frame_checksum(reinterpret_cast<const unsigned char*>(v.raw.depth), v.info().depth_stride,
                        v.raw.image, v.info().image_stride, v.info().width, v.info().height,
                        v.info().image_channels);
}

TEST(RingWriter, CreatesTheFileWith0640AndANewSessionEachTime) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  std::uint64_t first = 0;
  {
    RingWriter writer(path, small_ring());
    struct stat st {};
    ASSERT_EQ(stat(path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0640u);
    EXPECT_EQ(st.st_uid, getuid());
    first = writer.session_id();
    EXPECT_NE(first, 0u);
  }
  EXPECT_FALSE(std::filesystem::exists(path)) << "a stopped writer removes its ring";
  RingWriter again(path, small_ring());
  EXPECT_NE(again.session_id(), first);
}

TEST(RingWriter, RejectsBadGeometryAndMismatchedFrames) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  EXPECT_THROW(RingWriter(path, small_ring(2)), Error);
  RingOptions zero = small_ring();
  zero.width = 0;
  EXPECT_THROW(RingWriter(path, zero), Error);
  RingOptions colour2 = small_ring();
  colour2.image_channels = 2;
  EXPECT_THROW(RingWriter(path, colour2), Error);
  EXPECT_THROW(RingWriter(dir.path() / "missing" / "depth.shm", small_ring()), Error);

  RingWriter writer(path, small_ring());
  Image<float> wrong(kWidth + 1, kHeight);
  EXPECT_THROW(writer.write(wrong.cview(), {}, {}), Error);
  Image<float> depth(kWidth, kHeight);
  Image<std::uint8_t> colour(kWidth, kHeight, 3);
  EXPECT_THROW(writer.write(depth.cview(), colour.cview(), {}), Error);
  EXPECT_THROW(writer.write(depth.cview(), {}, {}), Error) << "depth without its image";
  EXPECT_EQ(writer.published(), 0u);
}

TEST(RingWriter, DefaultDirectoryFollowsRuntimeDirectory) {
  TempDir dir;
  const char* old = std::getenv("RUNTIME_DIRECTORY");
  const std::string saved = old ? old : "";
  setenv("RUNTIME_DIRECTORY", (dir.path().string() + ":/elsewhere").c_str(), 1);
  EXPECT_EQ(RingWriter::default_directory(), dir.path());
  if (old)
    setenv("RUNTIME_DIRECTORY", saved.c_str(), 1);
  else
    unsetenv("RUNTIME_DIRECTORY");
}

TEST(RingClient, NoFrameBeforeTheFirstPublish) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  EXPECT_EQ(c.session_id(), writer.session_id());
  EXPECT_FALSE(c.latest().has_value());
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_latest(c.handle(), &v), DCO_E_NO_FRAME);
}

TEST(RingClient, LatestIsTheNewestFrameWithItsMetadataAndAlignedPixels) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  for (std::uint64_t seq = 100; seq < 105; ++seq) publish_pattern(writer, seq);
  const auto v = c.latest();
  ASSERT_TRUE(v.has_value());
  const dco_frame_info& info = v->info();
  EXPECT_EQ(info.frame_seq, 104u);
  EXPECT_EQ(info.publish_index, 5u);
  EXPECT_EQ(info.session_id, writer.session_id());
  EXPECT_EQ(info.capture_ns, 104000);
  EXPECT_GT(info.publish_ns, 0);
  EXPECT_DOUBLE_EQ(info.fx, 604.0);
  EXPECT_DOUBLE_EQ(info.cy, 240.25);
  EXPECT_DOUBLE_EQ(info.baseline_m, 0.12);
  EXPECT_EQ(info.width, static_cast<std::uint32_t>(kWidth));
  EXPECT_EQ(info.height, static_cast<std::uint32_t>(kHeight));
  EXPECT_EQ(info.image_channels, 1u);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v->raw.depth) % 64, 0u);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v->raw.image) % 64, 0u);
  EXPECT_EQ(info.depth_stride % 64, 0u);
  EXPECT_EQ(info.image_stride % 64, 0u);
  EXPECT_EQ(view_checksum(*v), expected_checksum(104, kWidth, kHeight, true));
  EXPECT_FLOAT_EQ(v->depth_row(7)[5], pattern_depth(104, 5, 7));
  EXPECT_EQ(v->image_row(3)[9], pattern_image(104, 9, 3));
  EXPECT_TRUE(c.still_valid(*v));
}

TEST(RingClient, AViewStaysValidUntilItsSlotIsReused) {
  TempDir dir;
  constexpr int kSlots = 3;
  RingWriter writer(dir.path() / "depth.shm", small_ring(kSlots));
  client::Client c = connect(writer.path());
  publish_pattern(writer, 1);
  const auto v = c.latest();
  ASSERT_TRUE(v.has_value());
  // The writer never opens the newest slot, so a view survives slot_count - 1 more frames.
  for (int i = 0; i < kSlots - 1; ++i) {
    publish_pattern(writer, 2 + static_cast<std::uint64_t>(i));
    EXPECT_TRUE(c.still_valid(*v)) << "after " << i + 1 << " frames";
  }
  writer.begin_write();
  EXPECT_FALSE(c.still_valid(*v)) << "the slot is open for writing";
  std::vector<float> depth(kWidth * kHeight);
  dco_frame_buffer buf;
  dco_frame_buffer_init(&buf);
  buf.depth = depth.data();
  buf.depth_stride = kWidth * sizeof(float);
  buf.depth_capacity = depth.size() * sizeof(float);
  EXPECT_FALSE(c.copy(*v, buf));
  EXPECT_EQ(dco_client_copy(c.handle(), &v->raw, &buf), DCO_E_OVERTAKEN);
  writer.publish({});
  EXPECT_FALSE(c.still_valid(*v));
}

TEST(RingClient, ReadLatestCopiesAnUntornFrameIntoCallerMemory) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  publish_pattern(writer, 41);
  publish_pattern(writer, 42);
  constexpr std::size_t kDepthStride = kWidth * sizeof(float) + 12;  // unpadded, odd stride
  std::vector<unsigned char> depth(kDepthStride * kHeight);
  std::vector<std::uint8_t> image(kWidth * kHeight);
  dco_frame_buffer buf;
  dco_frame_buffer_init(&buf);
  buf.depth = reinterpret_cast<float*>(depth.data());
  buf.depth_stride = kDepthStride;
  buf.depth_capacity = depth.size();
  buf.image = image.data();
  buf.image_stride = kWidth;
  buf.image_capacity = image.size();
  const auto info = c.read_latest(buf);
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->frame_seq, 42u);
  EXPECT_EQ(frame_checksum(depth.data(), kDepthStride, image.data(), kWidth, kWidth, kHeight, 1),
            expected_checksum(42, kWidth, kHeight, true));

  // The last row needs no padding after it; one byte less than that is too small.
  dco_frame_info out;
  dco_frame_info_init(&out);
  buf.depth_capacity = kDepthStride * (kHeight - 1) + kWidth * sizeof(float);
  EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_OK);
  buf.depth_capacity -= 1;
  EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_E_BUFFER_TOO_SMALL);
  buf.depth_capacity = depth.size();
  buf.image_stride = kWidth - 1;
  EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_E_BUFFER_TOO_SMALL);
}

TEST(RingClient, RingWithoutImageHasNoImagePointer) {
  TempDir dir;
  RingOptions o = small_ring();
  o.image_channels = 0;
  RingWriter writer(dir.path() / "depth.shm", o);
  client::Client c = connect(writer.path());
  Image<float> depth(kWidth, kHeight);
  depth.fill(1.5f);
  writer.write(depth.cview(), {}, {});
  const auto v = c.latest();
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->raw.image, nullptr);
  EXPECT_EQ(v->info().image_channels, 0u);
  EXPECT_FLOAT_EQ(v->depth_row(kHeight - 1)[kWidth - 1], 1.5f);
}

TEST(RingClient, WaitNextReturnsOnlyNewerFramesAndTimesOut) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  publish_pattern(writer, 1);
  const auto first = c.wait_next(std::chrono::milliseconds(100));
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->info().frame_seq, 1u);

  const auto start = std::chrono::steady_clock::now();
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_wait_next(c.handle(), 60, &v), DCO_E_TIMEOUT);
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_GE(waited, std::chrono::milliseconds(60));
  EXPECT_LT(waited, std::chrono::milliseconds(1000));
  EXPECT_NE(std::string(dco_client_last_error()).find("no new frame"), std::string::npos);

  publish_pattern(writer, 2);
  publish_pattern(writer, 3);
  const auto next = c.wait_next(std::chrono::milliseconds(100));
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->info().frame_seq, 3u) << "wait_next skips to the newest frame";
}

TEST(RingClient, WriterGoneAfterACleanStop) {
  TempDir dir;
  auto writer = std::make_unique<RingWriter>(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer->path());
  publish_pattern(*writer, 1);
  ASSERT_TRUE(c.wait_next(std::chrono::milliseconds(100)).has_value());
  writer.reset();
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_wait_next(c.handle(), 2000, &v), DCO_E_WRITER_GONE);
  EXPECT_THROW(c.wait_next(std::chrono::milliseconds(100)), client::Error);
}

// The writer publishes and closes right away while the client waits: however the two land
// between the client's looks, the frame comes before the "writer stopped".
TEST(RingClient, TheLastFrameBeforeAStopIsDelivered) {
  TempDir dir;
  for (int round = 0; round < 100; ++round) {
    auto writer = std::make_unique<RingWriter>(dir.path() / "depth.shm", small_ring());
    client::Client c = connect(writer->path());
    std::thread stop([&] {
      publish_pattern(*writer, static_cast<std::uint64_t>(round + 1));
      writer.reset();
    });
    dco_frame_view v;
    dco_frame_view_init(&v);
    int frames = 0;
    dco_status status = DCO_OK;
    while ((status = dco_client_wait_next(c.handle(), 2000, &v)) == DCO_OK) ++frames;
    stop.join();
    ASSERT_EQ(status, DCO_E_WRITER_GONE) << "round " << round;
    ASSERT_EQ(frames, 1) << "round " << round;
  }
}

TEST(RingClient, FollowsARestartedWriterToItsNewSession) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  auto old_writer = std::make_unique<RingWriter>(path, small_ring());
  client::Client c = connect(path);
  publish_pattern(*old_writer, 10);
  const auto old_view = c.wait_next(std::chrono::milliseconds(100));
  ASSERT_TRUE(old_view.has_value());
  const std::uint64_t old_session = c.session_id();

  // A new writer replaces the file while the old one still runs (as a restart does).
  RingWriter writer(path, small_ring(5));
  publish_pattern(writer, 1);
  const auto v = c.wait_next(std::chrono::milliseconds(1000));
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->info().session_id, writer.session_id());
  EXPECT_NE(writer.session_id(), old_session);
  EXPECT_EQ(v->info().frame_seq, 1u);
  EXPECT_EQ(v->info().publish_index, 1u) << "publish indices restart with the session";
  EXPECT_EQ(view_checksum(*v), expected_checksum(1, kWidth, kHeight, true));
  EXPECT_FALSE(c.still_valid(*old_view)) << "a view of the old session is never valid";
  old_writer.reset();
  EXPECT_TRUE(std::filesystem::exists(path)) << "the old writer leaves the new ring alone";
  publish_pattern(writer, 2);
  const auto after = c.wait_next(std::chrono::milliseconds(1000));
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->info().frame_seq, 2u);
}

}  // namespace
}  // namespace dco::ipc::testing
