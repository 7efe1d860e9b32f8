// Readers that poll through a write (dco_client_options::poll_us): the writer's write-begun
// counter, every frame still delivered once and in order however a write compares with the
// polling time, a clean end when the writer stops, and the short time slice a polling wait asks
// for.

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "dco/ipc/ring_layout.hpp"
#include "ipc_test_support.hpp"
#include "support/time_slice_probe.hpp"

namespace dco::ipc::testing {
namespace {

using namespace std::chrono_literals;

constexpr int kWidth = 64;
constexpr int kHeight = 32;

RingOptions small_ring() {
  RingOptions o;
  o.width = kWidth;
  o.height = kHeight;
  o.image_channels = 1;
  o.slot_count = 3;
  return o;
}

client::Client polling_client(const std::filesystem::path& path, std::uint32_t poll_us) {
  client::Options o;
  o.path = path.string();
  o.poll_us = poll_us;
  return client::Client(o);
}

// The ring's header as a reader maps it.
class HeaderMap {
 public:
  explicit HeaderMap(const std::filesystem::path& path) {
    fd_ = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) return;
    void* p = mmap(nullptr, sizeof(layout::RingHeader), PROT_READ, MAP_SHARED, fd_, 0);
    if (p != MAP_FAILED) header_ = static_cast<const layout::RingHeader*>(p);
  }
  ~HeaderMap() {
    if (header_ != nullptr)
      munmap(const_cast<layout::RingHeader*>(header_), sizeof(layout::RingHeader));
    if (fd_ >= 0) close(fd_);
  }
  const layout::RingHeader* operator->() const { return header_; }
  bool ok() const { return header_ != nullptr; }

 private:
  int fd_ = -1;
  const layout::RingHeader* header_ = nullptr;
};

TEST(RingPolling, WritesBegunCountsWritesAndEqualsThePublishCountBetweenThem) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  HeaderMap h(writer.path());
  ASSERT_TRUE(h.ok());
  EXPECT_EQ(h->writes_begun.load(), 0u);
  for (std::uint64_t seq = 1; seq <= 3; ++seq) {
    RingWriter::Slot slot = writer.begin_write();
    (void)slot;
    EXPECT_EQ(h->writes_begun.load(), seq) << "a write announces itself when it begins";
    EXPECT_EQ(h->publish_count.load(), seq - 1);
    FrameMeta meta;
    meta.frame_seq = seq;
    writer.publish(meta);
    EXPECT_EQ(h->writes_begun.load(), h->publish_count.load());
  }
}

// A writer that takes `write_time` to fill each slot, publishing every `period`.
void write_slowly(RingWriter& writer, std::uint64_t frames, std::chrono::microseconds write_time,
                  std::chrono::microseconds period) {
  for (std::uint64_t seq = 1; seq <= frames; ++seq) {
    const auto start = std::chrono::steady_clock::now();
    const RingWriter::Slot slot = writer.begin_write();
    std::this_thread::sleep_for(write_time);
    fill_pattern(slot, seq);
    FrameMeta meta;
    meta.frame_seq = seq;
    writer.publish(meta);
    std::this_thread::sleep_until(start + period);
  }
}

struct Received {
  std::vector<std::uint64_t> seqs;
  int torn = 0;
  std::string failure;
};

// Takes frames until the last one; every accepted view is checked against its frame's pattern.
Received read_until(client::Client& c, std::uint64_t last) {
  Received r;
  while (r.seqs.empty() || r.seqs.back() < last) {
    dco_frame_view v;
    dco_frame_view_init(&v);
    const dco_status s = dco_client_wait_next(c.handle(), 2000, &v);
    if (s != DCO_OK) {
      r.failure = std::string(dco_client_strerror(s)) + ": " + dco_client_last_error();
      break;
    }
    const std::uint64_t sum =
        frame_checksum(reinterpret_cast<const unsigned char*>(v.depth), v.info.depth_stride,
                       v.image, v.info.image_stride, kWidth, kHeight, 1);
    if (dco_client_still_valid(c.handle(), &v) &&
        sum != expected_checksum(v.info.frame_seq, kWidth, kHeight, true))
      ++r.torn;
    r.seqs.push_back(v.info.frame_seq);
  }
  return r;
}

TEST(RingPolling, EveryFrameArrivesOnceAndInOrderWhetherTheWriteIsShorterOrLongerThanThePoll) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  constexpr std::uint64_t kFrames = 60;
  // 50 us of polling runs out during a 400 us write (the reader sleeps again until the publish);
  // 20 ms outlasts it (the reader sees the publish while polling); 0 only ever sleeps.
  const std::vector<std::uint32_t> polls{50, 20'000, 0};
  std::vector<Received> got(polls.size());
  std::vector<std::thread> readers;
  for (std::size_t i = 0; i < polls.size(); ++i)
    readers.emplace_back([&, i] {
      client::Client c = polling_client(writer.path(), polls[i]);
      got[i] = read_until(c, kFrames);
    });
  std::this_thread::sleep_for(20ms);  // the readers are waiting before the first frame
  write_slowly(writer, kFrames, 400us, 3ms);
  for (auto& t : readers) t.join();
  for (std::size_t i = 0; i < polls.size(); ++i) {
    SCOPED_TRACE("poll_us " + std::to_string(polls[i]));
    const Received& r = got[i];
    EXPECT_EQ(r.failure, "");
    EXPECT_EQ(r.torn, 0);
    ASSERT_FALSE(r.seqs.empty());
    EXPECT_EQ(r.seqs.back(), kFrames);
    for (std::size_t k = 1; k < r.seqs.size(); ++k)
      EXPECT_LT(r.seqs[k - 1], r.seqs[k]) << "a frame came twice or out of order";
    // A frame is skipped only when the reader falls more than a 3 ms period behind.
    EXPECT_GE(r.seqs.size(), kFrames * 3 / 4);
  }
}

TEST(RingPolling, AStoppingWriterEndsAPollingWait) {
  TempDir dir;
  auto writer = std::make_unique<RingWriter>(dir.path() / "depth.shm", small_ring());
  client::Client c = polling_client(writer->path(), 20'000);
  publish_pattern(*writer, 1);
  ASSERT_TRUE(c.wait_next(100ms).has_value());
  std::thread stopper([&] {
    std::this_thread::sleep_for(30ms);
    writer.reset();
  });
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_wait_next(c.handle(), 5000, &v), DCO_E_WRITER_GONE)
      << dco_client_last_error();
  stopper.join();
}

TEST(RingPolling, APollingWaitAsksForAShortTimeSliceForItsThreadAndKeepsItsNiceValue) {
  if (!dco::testing::kernel_keeps_time_slices())
    GTEST_SKIP() << "this kernel does not keep time slices";
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  for (const std::uint32_t poll_us : {0u, 2000u}) {
    SCOPED_TRACE("poll_us " + std::to_string(poll_us));
    client::Client c = polling_client(writer.path(), poll_us);
    std::atomic<pid_t> tid{0};
    std::atomic<bool> waiting{false};
    SchedAttr before{}, after{};
    dco_status status = DCO_OK;
    std::thread reader([&] {
      // A nice value of its own, which the slice must not take away (raising it needs no
      // privilege; lowering it back would).
      setpriority(PRIO_PROCESS, 0, 5);
      dco::testing::set_time_slice(2'000'000);  // not inherited from an earlier polling wait
      thread_sched_attr(0, before);
      tid = static_cast<pid_t>(syscall(SYS_gettid));
      waiting = true;
      dco_frame_view v;
      dco_frame_view_init(&v);
      status = dco_client_wait_next(c.handle(), 400, &v);  // nothing is published: times out
      thread_sched_attr(0, after);
    });
    while (!waiting) std::this_thread::yield();
    std::this_thread::sleep_for(100ms);
    SchedAttr during;
    const bool read_during = thread_sched_attr(tid, during);
    reader.join();
    ASSERT_TRUE(read_during);
    EXPECT_EQ(status, DCO_E_TIMEOUT);
    ASSERT_EQ(before.sched_nice, 5);
    ASSERT_EQ(before.sched_runtime, 2'000'000u);
    EXPECT_EQ(during.sched_nice, 5);
    if (poll_us == 0) {
      EXPECT_EQ(during.sched_runtime, before.sched_runtime) << "a sleeping wait keeps its slice";
      EXPECT_EQ(after.sched_runtime, before.sched_runtime);
    } else {
      EXPECT_EQ(during.sched_runtime, 100'000u) << "a polling wait asks for 0.1 ms";
      EXPECT_EQ(after.sched_runtime, 100'000u) << "and the thread keeps it";
    }
    EXPECT_EQ(after.sched_nice, 5);
    EXPECT_EQ(after.sched_policy, before.sched_policy);
  }
}

// A thread's reset-on-fork flag is part of its policy (sched_setscheduler's SCHED_RESET_ON_FORK):
// the time slice a polling wait asks for keeps it.
TEST(RingPolling, TheTimeSliceRequestKeepsTheThreadsResetOnFork) {
  int before = -1, after = -1;
  bool set = false;
  std::thread([&] {
    sched_param p{};
    if (sched_setscheduler(0, SCHED_OTHER | SCHED_RESET_ON_FORK, &p) != 0) return;
    before = sched_getscheduler(0);
    SchedAttr attr;
    set = thread_sched_attr(0, attr) && dco::set_time_slice(attr, 100'000);
    after = sched_getscheduler(0);
  }).join();
  if (before < 0) GTEST_SKIP() << "no SCHED_RESET_ON_FORK here";
  ASSERT_TRUE(set);
  EXPECT_EQ(before, SCHED_OTHER | SCHED_RESET_ON_FORK);
  EXPECT_EQ(after, before);
}

TEST(RingPolling, PollTimeIsCheckedAndCallersBuiltBeforeItGetTheDefault) {
  TempDir dir;
  RingWriter writer(dir.path() / "depth.shm", small_ring());
  const std::string path = writer.path().string();
  dco_client_options o;
  dco_client_options_init(&o);
  o.path = path.c_str();
  EXPECT_EQ(o.poll_us, 0u);
  dco_client* c = nullptr;
  o.poll_us = 100'001;
  EXPECT_EQ(dco_client_open(&o, &c), DCO_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(dco_client_last_error()).find("poll_us 100001"), std::string::npos)
      << dco_client_last_error();
  o.poll_us = 100'000;
  ASSERT_EQ(dco_client_open(&o, &c), DCO_OK) << dco_client_last_error();
  dco_client_close(c);
  // An options struct from before poll_us: its size ends where the field begins, and the
  // garbage past it is never read.
  o.poll_us = 0xdeadbeef;
  o.struct_size = offsetof(dco_client_options, poll_us);
  ASSERT_EQ(dco_client_open(&o, &c), DCO_OK) << dco_client_last_error();
  publish_pattern(writer, 1);
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_wait_next(c, 1000, &v), DCO_OK);
  dco_client_close(c);
}

}  // namespace
}  // namespace dco::ipc::testing
