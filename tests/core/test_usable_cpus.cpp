#include "dco/core/usable_cpus.hpp"

#include <gtest/gtest.h>
#include <sched.h>

#include <thread>

#include "support/one_cpu.hpp"

namespace dco {
namespace {

TEST(UsableCpus, CountsTheThreadsAffinityMask) {
  cpu_set_t set;
  CPU_ZERO(&set);
  ASSERT_EQ(sched_getaffinity(0, sizeof(set), &set), 0);
  EXPECT_EQ(usable_cpus(), CPU_COUNT(&set));
  EXPECT_GE(usable_cpus(), 1);
  EXPECT_LE(usable_cpus(), static_cast<int>(std::thread::hardware_concurrency()));
  {
    const testing::OneCpu one;
    ASSERT_TRUE(one.ok());
    EXPECT_EQ(usable_cpus(), 1);
  }
  EXPECT_EQ(usable_cpus(), CPU_COUNT(&set));
}

}  // namespace
}  // namespace dco
