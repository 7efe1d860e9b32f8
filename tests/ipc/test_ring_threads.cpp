// Writer and readers on threads of one process, so ThreadSanitizer sees the library's own state
// (per-thread error text, per-handle bookkeeping) under concurrency. Pixels a reader accepts must
// match their frame's checksum.

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

constexpr int kWidth = 64;
constexpr int kHeight = 48;

struct ReaderCounts {
  int accepted = 0;
  int rejected = 0;
  int torn_accepted = 0;
};

TEST(RingThreads, ReadersOnThreadsNeverAcceptATornFrame) {
  TempDir dir;
  RingOptions o;
  o.width = kWidth;
  o.height = kHeight;
  o.image_channels = 1;
  o.slot_count = 3;
  RingWriter writer(dir.path() / "depth.shm", o);
  std::atomic<bool> done{false};

  constexpr int kReaders = 4;
  std::vector<ReaderCounts> counts(kReaders);
  std::vector<std::thread> readers;
  for (int r = 0; r < kReaders; ++r) {
    readers.emplace_back([&, r] {
      client::Options co;
      co.path = writer.path().string();
      client::Client c(co);
      std::vector<float> depth(kWidth * kHeight);
      std::vector<std::uint8_t> image(kWidth * kHeight);
      dco_frame_buffer buf;
      dco_frame_buffer_init(&buf);
      buf.depth = depth.data();
      buf.depth_stride = kWidth * sizeof(float);
      buf.depth_capacity = depth.size() * sizeof(float);
      buf.image = image.data();
      buf.image_stride = kWidth;
      buf.image_capacity = image.size();
      ReaderCounts& n = counts[static_cast<std::size_t>(r)];
      while (!done.load()) {
        const auto v = c.wait_next(std::chrono::milliseconds(20));
        if (!v) continue;
        // Odd readers copy; even ones read in place and then check the view.
        std::uint64_t sum = 0;
        bool ok = false;
        if (r % 2 == 1) {
          ok = c.copy(*v, buf);
          sum = frame_checksum(reinterpret_cast<const unsigned char*>(depth.data()),
                               buf.depth_stride, image.data(), kWidth, kWidth, kHeight, 1);
        } else {
          sum = frame_checksum(reinterpret_cast<const unsigned char*>(v->raw.depth),
                               v->info().depth_stride, v->raw.image, v->info().image_stride, kWidth,
                               kHeight, 1);
          ok = c.still_valid(*v);
        }
        if (!ok) {
          ++n.rejected;
          continue;
        }
        ++n.accepted;
        if (sum != expected_checksum(v->info().frame_seq, kWidth, kHeight, true)) ++n.torn_accepted;
      }
    });
  }

  constexpr std::uint64_t kFrames = 400;
  for (std::uint64_t seq = 1; seq <= kFrames; ++seq) {
    publish_pattern(writer, seq);
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  done.store(true);
  for (auto& t : readers) t.join();
  for (int r = 0; r < kReaders; ++r) {
    SCOPED_TRACE(r);
    EXPECT_EQ(counts[static_cast<std::size_t>(r)].torn_accepted, 0);
    EXPECT_GT(counts[static_cast<std::size_t>(r)].accepted, 10);
  }
  EXPECT_EQ(writer.published(), kFrames);
}

}  // namespace
}  // namespace dco::ipc::testing
