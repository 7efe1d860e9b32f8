#include "dco/core/buffer_pool.hpp"

#include <atomic>
#include <set>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace dco {
namespace {

TEST(BufferPool, ImagesArePreSized) {
  BufferPool<float> pool(2, 32, 16, 3);
  EXPECT_EQ(pool.capacity(), 2u);
  EXPECT_EQ(pool.available(), 2u);
  auto lease = pool.try_acquire();
  ASSERT_TRUE(lease);
  EXPECT_EQ(lease->image().width(), 32);
  EXPECT_EQ(lease->image().height(), 16);
  EXPECT_EQ(lease->view().channels, 3);
}

TEST(BufferPool, ExhaustionReturnsNothing) {
  BufferPool<std::uint8_t> pool(3, 8, 8);
  std::vector<BufferPool<std::uint8_t>::Lease> held;
  std::set<const std::uint8_t*> buffers;
  for (int i = 0; i < 3; ++i) {
    auto lease = pool.try_acquire();
    ASSERT_TRUE(lease.has_value());
    buffers.insert(lease->image().data());
    held.push_back(std::move(*lease));
  }
  EXPECT_EQ(buffers.size(), 3u);  // three distinct buffers
  EXPECT_EQ(pool.available(), 0u);
  EXPECT_FALSE(pool.try_acquire().has_value());
  held.pop_back();
  EXPECT_EQ(pool.available(), 1u);
  EXPECT_TRUE(pool.try_acquire().has_value());
}

TEST(BufferPool, LeaseReturnsOnDestruction) {
  BufferPool<float> pool(1, 4, 4);
  const float* data = nullptr;
  {
    auto lease = pool.try_acquire();
    ASSERT_TRUE(lease);
    data = lease->image().data();
    EXPECT_EQ(pool.available(), 0u);
  }
  EXPECT_EQ(pool.available(), 1u);
  auto again = pool.try_acquire();
  ASSERT_TRUE(again);
  EXPECT_EQ(again->image().data(), data);  // the same buffer comes back, nothing reallocated
}

TEST(BufferPool, MoveTransfersOwnership) {
  BufferPool<float> pool(2, 4, 4);
  auto first = pool.try_acquire();
  ASSERT_TRUE(first);
  const std::size_t index = first->index();
  BufferPool<float>::Lease moved(std::move(*first));
  EXPECT_FALSE(*first);  // NOLINT(bugprone-use-after-move): moved-from lease is empty
  EXPECT_TRUE(moved);
  EXPECT_EQ(moved.index(), index);
  first.reset();  // destroying the moved-from lease must not return the buffer
  EXPECT_EQ(pool.available(), 1u);

  auto second = pool.try_acquire();
  ASSERT_TRUE(second);
  EXPECT_EQ(pool.available(), 0u);
  moved = std::move(*second);  // move-assign releases what `moved` held
  EXPECT_EQ(pool.available(), 1u);
  moved.release();
  EXPECT_FALSE(moved);
  EXPECT_EQ(pool.available(), 2u);
  moved.release();  // idempotent
  EXPECT_EQ(pool.available(), 2u);
}

TEST(BufferPool, ConcurrentAcquireNeverHandsOutTwice) {
  BufferPool<std::uint8_t> pool(4, 2, 2);
  std::atomic<int> in_use{0}, max_in_use{0}, failures{0};
  auto worker = [&] {
    for (int i = 0; i < 2000; ++i) {
      auto lease = pool.try_acquire();
      if (!lease) {
        ++failures;
        continue;
      }
      const int now = ++in_use;
      int seen = max_in_use.load();
      while (now > seen && !max_in_use.compare_exchange_weak(seen, now)) {
      }
      lease->image().at(0, 0) = static_cast<std::uint8_t>(i);
      --in_use;
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  EXPECT_LE(max_in_use.load(), 4);
  EXPECT_EQ(pool.available(), 4u);
}

}  // namespace
}  // namespace dco
