// One process, writer and client side by side: what a reader sees of a frame and when a view
// stops being valid.

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
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

// A writer killed while it built its ring leaves the temporary file, a whole ring of memory under
// /run: the next writer of that name removes it, but not one a live writer is still building.
TEST(RingWriter, RemovesTheTemporaryRingsOfKilledWriters) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const auto abandoned = dir.path() / "depth.shm.tmp.00000000deadbeef";
  const auto building = dir.path() / "depth.shm.tmp.00000000feedface";
  const auto other = dir.path() / "other.shm.tmp.00000000deadbeef";
  for (const auto& p : {abandoned, building, other}) std::ofstream(p) << "part of a ring";
  const int live = open(building.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(live, 0);
  ASSERT_EQ(flock(live, LOCK_EX | LOCK_NB), 0);
  {
    RingWriter writer(path, small_ring());
    EXPECT_FALSE(std::filesystem::exists(abandoned));
    EXPECT_TRUE(std::filesystem::exists(building)) << "its writer still holds it";
    EXPECT_TRUE(std::filesystem::exists(other)) << "another ring's name";
  }
  close(live);
}

// A stopping writer checks that the ring at the path is still its own and removes it as one step
// against other writers, which hold the directory's lock to move theirs into place: it never
// removes a successor's ring that was moved in between.
TEST(RingWriter, AStoppingWriterRemovesItsRingOnlyUnderTheDirectoryLock) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  auto writer = std::make_unique<RingWriter>(path, small_ring());
  const int directory = open(dir.path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  ASSERT_GE(directory, 0);
  ASSERT_EQ(flock(directory, LOCK_EX), 0);
  std::atomic<bool> began{false}, ended{false};
  std::thread stopping([&] {
    began = true;
    writer.reset();
    ended = true;
  });
  while (!began) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_FALSE(ended) << "the stopping writer did not wait for the directory's lock";
  EXPECT_TRUE(std::filesystem::exists(path)) << "removed without the directory's lock";
  // A successor moves its ring into place while the stopping writer waits.
  const auto successor = dir.path() / "successor";
  std::ofstream(successor) << "a newer ring";
  ASSERT_EQ(rename(successor.c_str(), path.c_str()), 0);
  flock(directory, LOCK_UN);
  stopping.join();
  close(directory);
  EXPECT_TRUE(std::filesystem::exists(path)) << "the successor's ring was removed";
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
  // Views with the ring's size but no pixels.
  const ImageView<const std::uint8_t> no_image(nullptr, kWidth, kHeight, 1, kWidth);
  EXPECT_THROW(writer.write(depth.cview(), no_image, {}), Error);
  const ImageView<const float> no_depth(nullptr, kWidth, kHeight, 1, kWidth);
  Image<std::uint8_t> grey(kWidth, kHeight);
  EXPECT_THROW(writer.write(no_depth, grey.cview(), {}), Error);
  EXPECT_EQ(writer.published(), 0u);
}

// In a child with a mount namespace of its own: a 1 MiB tmpfs at `dir`, then a ring larger than
// that. Exit 0: a dco::Error naming the reservation and no file left; 77: no namespace here.
int ring_on_a_full_tmpfs(const std::filesystem::path& dir) {
  if (unshare(CLONE_NEWNS) != 0) {
    // Not root: a user namespace that maps our uid lets us mount all the same.
    const uid_t uid = getuid();
    const gid_t gid = getgid();
    if (unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0) return 77;
    std::ofstream("/proc/self/setgroups") << "deny";
    std::ofstream("/proc/self/uid_map") << "0 " << uid << " 1";
    std::ofstream("/proc/self/gid_map") << "0 " << gid << " 1";
  }
  if (mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
      mount("none", dir.c_str(), "tmpfs", 0, "size=1m") != 0)
    return 77;
  RingOptions big;
  big.width = 640;
  big.height = 360;
  big.image_channels = 1;
  try {
    RingWriter writer(dir / "depth.shm", big);  // about 4.6 MB
    return 2;
  } catch (const Error& e) {
    if (std::string(e.what()).find("reserve") == std::string::npos) return 3;
  }
  return std::filesystem::is_empty(dir) ? 0 : 4;
}

TEST(RingWriter, AFullTmpfsIsAnErrorNotABusFault) {
  TempDir dir;
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(ring_on_a_full_tmpfs(dir.path()));
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  if (WEXITSTATUS(status) == 77) GTEST_SKIP() << "no mount namespace for a small tmpfs here";
  EXPECT_EQ(WEXITSTATUS(status), 0) << "2: no error, 3: another error, 4: a file left behind";
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

// An environment variable set (or, with nullptr, unset) for a scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) saved_ = old;
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;
  ~ScopedEnv() {
    if (saved_)
      setenv(name_, saved_->c_str(), 1);
    else
      unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

// Run by hand: the same directory of the user's own at every start, so clients follow a restart.
TEST(RingWriter, DefaultDirectoryByHandIsTheUsersOwnAndTheSameEachTime) {
  if (access("/run/dcod", W_OK | X_OK) == 0) GTEST_SKIP() << "/run/dcod is writable here";
  TempDir dir;
  const ScopedEnv runtime("RUNTIME_DIRECTORY", nullptr);
  const ScopedEnv xdg("XDG_RUNTIME_DIR", dir.path().c_str());
  const auto first = RingWriter::default_directory();
  EXPECT_EQ(first, dir.path() / "dcod");
  EXPECT_EQ(RingWriter::default_directory(), first);
  struct stat st {};
  ASSERT_EQ(stat(first.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0077, 0u);
  // One that others can write to is refused: they could put their own file where clients look.
  ASSERT_EQ(chmod(first.c_str(), 0777), 0);
  EXPECT_THROW(RingWriter::default_directory(), Error);
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

  // Strides whose product with the rows wraps round to a small size are too small too, and
  // nothing is written.
  buf.image_stride = kWidth;
  std::fill(depth.begin(), depth.end(), 0xAB);
  for (const std::size_t stride : {std::size_t{1} << 63, SIZE_MAX / (kHeight - 1) + 1, SIZE_MAX}) {
    buf.depth_stride = stride;
    EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_E_BUFFER_TOO_SMALL) << stride;
    buf.depth_stride = kDepthStride;
    buf.image_stride = stride;
    EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_E_BUFFER_TOO_SMALL) << stride;
    buf.image_stride = kWidth;
  }
  EXPECT_EQ(std::count(depth.begin(), depth.end(), 0xAB),
            static_cast<std::ptrdiff_t>(depth.size()));

  // A frame whose copy failed was not returned: wait_next still gives it.
  publish_pattern(writer, 43);
  buf.depth_capacity = 1;
  EXPECT_EQ(dco_client_read_latest(c.handle(), &buf, &out), DCO_E_BUFFER_TOO_SMALL);
  const auto next = c.wait_next(std::chrono::milliseconds(0));
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->info().frame_seq, 43u);
}

TEST(RingWriter, AWriteNeverPublishedIsWrittenAgainAndNeverLooksPublished) {
  TempDir dir;
  constexpr int kSlots = 3;
  RingWriter writer(dir.path() / "depth.shm", small_ring(kSlots));
  client::Client c = connect(writer.path());
  std::vector<std::uint64_t> seq_of_index = {0};  // frame_seq by publish index
  auto publish = [&](std::uint64_t seq) {
    EXPECT_EQ(publish_pattern(writer, seq), seq_of_index.size());
    seq_of_index.push_back(seq);
  };
  // Every frame the ring still hands out, by announcement, is one whole published frame.
  auto check_announced = [&] {
    std::vector<unsigned char> depth(kWidth * sizeof(float) * kHeight);
    std::vector<std::uint8_t> image(kWidth * kHeight);
    dco_frame_buffer buf;
    dco_frame_buffer_init(&buf);
    buf.depth = reinterpret_cast<float*>(depth.data());
    buf.depth_stride = kWidth * sizeof(float);
    buf.depth_capacity = depth.size();
    buf.image = image.data();
    buf.image_stride = kWidth;
    buf.image_capacity = image.size();
    int accepted = 0;
    for (std::uint32_t slot = 0; slot < kSlots; ++slot)
      for (std::uint64_t index = 1; index < seq_of_index.size(); ++index) {
        const auto info = c.read_announced(writer.session_id(), slot, index, buf);
        if (!info) continue;
        ++accepted;
        EXPECT_EQ(info->frame_seq, seq_of_index[index]);
        EXPECT_EQ(frame_checksum(depth.data(), buf.depth_stride, image.data(), kWidth, kWidth,
                                 kHeight, 1),
                  expected_checksum(seq_of_index[index], kWidth, kHeight, true))
            << "slot " << slot << ", index " << index;
      }
    return accepted;
  };
  for (std::uint64_t seq = 1; seq <= kSlots; ++seq) publish(seq);
  // A frame that fails half-way between begin_write and publish: the daemon catches the error
  // and goes on with the next frame.
  const RingWriter::Slot abandoned = writer.begin_write();
  for (int y = 0; y < kHeight; ++y) std::fill_n(abandoned.depth.row(y), kWidth, -1.0f);
  EXPECT_EQ(check_announced(), kSlots - 1) << "the open slot's frame is refused";
  EXPECT_EQ(writer.begin_write().index, abandoned.index) << "the open slot is written again";
  publish(10);
  EXPECT_EQ(writer.current_slot(), abandoned.index);
  // Round the ring twice, each frame first half-written: only whole frames are ever accepted.
  for (std::uint64_t seq = 11; seq < 11 + 2 * kSlots; ++seq) {
    const RingWriter::Slot open = writer.begin_write();
    for (int y = 0; y < kHeight / 2; ++y) open.depth.row(y)[0] = -2.0f;
    EXPECT_EQ(check_announced(), kSlots - 1);
    const auto newest = c.latest();
    ASSERT_TRUE(newest.has_value());
    EXPECT_EQ(newest->info().frame_seq, seq_of_index.back());
    publish(seq);
    EXPECT_EQ(check_announced(), kSlots);
  }
}

TEST(RingWriter, PublishWithoutAnOpenSlotThrows) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  EXPECT_THROW(writer.publish({}), dco::Error);
  publish_pattern(writer, 1);
  EXPECT_THROW(writer.publish({}), dco::Error);
  client::Client c = connect(writer.path());
  const auto v = c.latest();
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->info().frame_seq, 1u);
  EXPECT_TRUE(c.still_valid(*v));
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

  old_writer.reset();
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
  publish_pattern(writer, 2);
  const auto after = c.wait_next(std::chrono::milliseconds(1000));
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->info().frame_seq, 2u);
}

// A second daemon started by hand beside the service: it must not take the ring over, or the
// first would go on publishing into a file no client finds while its watchdog hears all is well.
TEST(RingWriter, RefusesAPathALiveWriterPublishesAt) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  auto first = std::make_unique<RingWriter>(path, small_ring());
  client::Client c = connect(path);
  try {
    RingWriter second(path, small_ring(5));
    ADD_FAILURE() << "a second writer took the ring over";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("another writer (pid " + std::to_string(getpid()) + ")"),
              std::string::npos)
        << e.what();
  }
  publish_pattern(*first, 3);
  const auto v = c.wait_next(std::chrono::milliseconds(1000));
  ASSERT_TRUE(v.has_value()) << "the first writer's clients read on";
  EXPECT_EQ(v->info().session_id, first->session_id());
  int left = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) left += e.path() != path;
  EXPECT_EQ(left, 0) << "the refused writer left its temporary ring behind";
  first.reset();
  RingWriter next(path, small_ring(5));  // once it has stopped, the path is free
}

// A ring put over a writer's own by someone else (a file moved there by hand): the writer's stop
// leaves it alone.
TEST(RingWriter, LeavesARingThatReplacedItsOwnAlone) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  auto writer = std::make_unique<RingWriter>(path, small_ring());
  const auto other = dir.path() / "other";
  std::ofstream(other) << "not this writer's";
  std::filesystem::rename(other, path);
  writer.reset();
  EXPECT_TRUE(std::filesystem::exists(path));
}

// Runs `body` in a child process and returns its exit status, or -1 when it is still running
// after `seconds` (it is then killed): a writer that blocks must fail a test, not hang it.
int exit_status_within(int seconds, const std::function<int()>& body) {
  const pid_t child = fork();
  if (child == 0) _exit(body());
  for (int i = 0; i < seconds * 100; ++i) {
    int status = 0;
    if (waitpid(child, &status, WNOHANG) == child)
      return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  return -1;
}

// A FIFO named like an abandoned temporary ring (anyone can make one in /dev/shm) must not
// block a writer's start for ever.
TEST(RingWriter, StartsBesideAFifoNamedLikeATemporaryRing) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const auto fifo = dir.path() / "depth.shm.tmp.00000000deadbeef";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(exit_status_within(10,
                               [&] {
                                 RingWriter writer(path, small_ring());
                                 return 0;
                               }),
            0);
  EXPECT_TRUE(std::filesystem::exists(fifo)) << "only abandoned rings are removed";
}

// Whoever can read the ring's directory (a client's group) can lock it: the writer's start and
// stop wait a second at most for it.
TEST(RingWriter, StartsAndStopsWhileSomeoneElseLocksTheDirectory) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const int dir_fd = open(dir.path().c_str(), O_RDONLY | O_DIRECTORY);
  ASSERT_GE(dir_fd, 0);
  ASSERT_EQ(flock(dir_fd, LOCK_EX), 0);
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(exit_status_within(10,
                               [&] {
                                 RingWriter writer(path, small_ring());
                                 return std::filesystem::exists(path) ? 0 : 3;
                               }),
            0);
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(5));
  EXPECT_FALSE(std::filesystem::exists(path)) << "the stop removed the ring";
  close(dir_fd);
}

TEST(RingClient, AViewOfARestartedWriterStaysMappedUntilAFrameIsReturned) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  auto old_writer = std::make_unique<RingWriter>(path, small_ring());
  client::Client c = connect(path);
  publish_pattern(*old_writer, 7);
  const auto kept = c.latest();
  ASSERT_TRUE(kept.has_value());
  // The daemon restarts, at another size, and has published nothing yet: a renderer keeps
  // drawing its last frame while the calls that look for a new one follow the path to the new
  // ring and find none.
  old_writer.reset();
  RingOptions larger = small_ring(5);
  larger.width = 2 * kWidth;
  larger.height = 2 * kHeight;
  RingWriter writer(path, larger);
  std::this_thread::sleep_for(std::chrono::milliseconds(30));  // a path check is due
  EXPECT_FALSE(c.latest().has_value());
  EXPECT_FALSE(c.wait_next(std::chrono::milliseconds(30)).has_value());
  EXPECT_FALSE(c.view_announced(writer.session_id(), 0, 1).has_value());
  EXPECT_EQ(c.session_id(), writer.session_id());
  EXPECT_FALSE(c.still_valid(*kept));
  EXPECT_EQ(view_checksum(*kept), expected_checksum(7, kWidth, kHeight, true))
      << "the old ring's pixels are still mapped";
  // Copied now, the kept view's frame is gone, which is what the copy says (not that a buffer
  // right for that frame is too small for the new ring).
  std::vector<float> depth(static_cast<std::size_t>(kWidth) * kHeight);
  dco_frame_buffer buf;
  dco_frame_buffer_init(&buf);
  buf.depth = depth.data();
  buf.depth_stride = kWidth * sizeof(float);
  buf.depth_capacity = depth.size() * sizeof(float);
  EXPECT_FALSE(c.copy(*kept, buf));
  EXPECT_NE(std::string(dco_client_last_error()).find("earlier ring"), std::string::npos)
      << dco_client_last_error();
  publish_pattern(writer, 1);
  const auto fresh = c.latest();
  ASSERT_TRUE(fresh.has_value());
  EXPECT_EQ(view_checksum(*fresh), expected_checksum(1, 2 * kWidth, 2 * kHeight, true));
}

// The reads that copy check the caller's buffer before they take a frame, and name themselves.
TEST(RingClient, ReadsCheckTheBufferFirstAndNameTheCall) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  dco_frame_buffer none;
  dco_frame_buffer_init(&none);  // no depth pointer
  // Nothing published yet: the bad buffer is still what is wrong.
  EXPECT_EQ(dco_client_read_latest(c.handle(), &none, nullptr), DCO_E_INVALID_ARGUMENT);
  EXPECT_EQ(dco_client_read_latest(c.handle(), nullptr, nullptr), DCO_E_INVALID_ARGUMENT);
  EXPECT_EQ(dco_client_read_announced(c.handle(), writer.session_id(), 0, 1, &none, nullptr),
            DCO_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(dco_client_last_error()).find("dco_client_read_announced"),
            std::string::npos)
      << dco_client_last_error();
  publish_pattern(writer, 3);
  float one = 0;
  dco_frame_buffer small;
  dco_frame_buffer_init(&small);
  small.depth = &one;
  small.depth_stride = sizeof one;
  small.depth_capacity = sizeof one;
  EXPECT_EQ(dco_client_read_latest(c.handle(), &small, nullptr), DCO_E_BUFFER_TOO_SMALL);
  const std::string message = dco_client_last_error();
  EXPECT_NE(message.find("dco_client_read_latest: depth buffer too small for 96x40"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find(std::to_string(kWidth * kHeight * sizeof(float)) + " bytes"),
            std::string::npos)
      << message;
}

// The likeliest setup fault, an app whose user is not in the ring's group: a permission error
// that says so, not an I/O error.
TEST(RingClient, ARingTheUserMayNotReadIsAPermissionError) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to read the ring as another user";
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  ASSERT_EQ(chmod(dir.path().c_str(), 0755), 0);  // the directory open to all, the ring 0640
  const pid_t child = fork();
  if (child == 0) {
    if (setgid(65534) != 0 || setuid(65534) != 0) _exit(3);
    dco_client_options o;
    dco_client_options_init(&o);
    const std::string p = writer.path().string();
    o.path = p.c_str();
    o.expected_uid = 0;
    dco_client* c = nullptr;
    const dco_status status = dco_client_open(&o, &c);
    const std::string message = dco_client_last_error();
    _exit(status == DCO_E_PERMISSION && message.find("group") != std::string::npos ? 0 : 1);
  }
  int wstatus = 0;
  ASSERT_EQ(waitpid(child, &wstatus, 0), child);
  ASSERT_TRUE(WIFEXITED(wstatus));
  EXPECT_EQ(WEXITSTATUS(wstatus), 0) << "3: could not drop to nobody; 1: not DCO_E_PERMISSION";
}

TEST(RingClient, WaitsLongerThanTheCApiCanSayAreCutNotWrapped) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  client::Client c = connect(writer.path());
  // Cast to the C call's 32-bit milliseconds, 2^32 + 1 ms was a 1 ms wait and 600 h a negative
  // one (an exception).
  std::uint64_t seq = 0;
  for (const std::chrono::milliseconds wait :
       {std::chrono::milliseconds((std::int64_t{1} << 32) + 1),
        std::chrono::milliseconds(std::chrono::hours(600))}) {
    std::thread later([&writer, s = ++seq] {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      publish_pattern(writer, s);
    });
    const auto v = c.wait_next(wait);
    later.join();
    ASSERT_TRUE(v.has_value()) << wait.count() << " ms";
    EXPECT_EQ(v->info().frame_seq, seq);
  }
  EXPECT_FALSE(c.wait_next(std::chrono::milliseconds(-5)).has_value()) << "a negative wait polls";
}

}  // namespace
}  // namespace dco::ipc::testing
