#include <gtest/gtest.h>

#include <chrono>

#include "dco/gpu/backend.hpp"
#include "stereo_cases.hpp"
#include "support/same_bytes.hpp"

namespace dco::gpu {
namespace {

using dco::testing::same_bytes;

// Tolerance: none. The device computes the CPU's integer costs, sums and decisions and the same
// IEEE float operations for the subpixel fit, so every byte must agree.
void expect_cuda_equals_cpu(const testing::StereoCase& c) {
  for (const auto& [variant, params] : testing::variants(c.params)) {
    SCOPED_TRACE(c.name + ", " + variant);
    const auto cpu = stereo::make_cpu_stereo_matcher(params);
    const auto cuda = make_cuda_stereo_matcher(params);
    Image<float> expected, actual;
    for (int frame = 0; frame < 2; ++frame) {
      cpu->compute(c.left.cview(), c.right.cview(), expected);
      cuda->compute(c.left.cview(), c.right.cview(), actual);
    }
    EXPECT_TRUE(same_bytes(actual.cview(), expected.cview()));
    EXPECT_TRUE(same_bytes(cuda->internal_raw_disparity(), cpu->internal_raw_disparity()));
    EXPECT_TRUE(same_bytes(cuda->internal_sparse_disparity(), cpu->internal_sparse_disparity()));
    EXPECT_TRUE(same_bytes(cuda->internal_left_gray(), cpu->internal_left_gray()));
    std::printf("%s, %s: CPU %.2f ms, CUDA %.2f ms (cost+aggregation+WTA %.2f ms)\n",
                c.name.c_str(), variant.c_str(), cpu->last_timings().total_ms,
                cuda->last_timings().total_ms, cuda->last_timings().initial_ms);
  }
}

class CudaStereo : public ::testing::Test {
 protected:
  void SetUp() override {
    const CudaDevice device = probe_cuda();
    if (!device.usable) GTEST_SKIP() << "no CUDA device to run on: " << device.why;
    std::printf("device: %s\n", device.describe().c_str());
  }
};

TEST_F(CudaStereo, RealPairsAreTheCpuStageBitForBit) {
  expect_cuda_equals_cpu(testing::real_pair("Teddy", "middlebury2003/Teddy/im2.png",
                                            "middlebury2003/Teddy/im6.png", 64));
  expect_cuda_equals_cpu(testing::real_pair("KITTI 000046",
                                            "kitti2015/000046/image_2/000046_10.png",
                                            "kitti2015/000046/image_3/000046_10.png", 96));
}

TEST_F(CudaStereo, HeadsetFramesAreTheCpuStageBitForBit) {
  expect_cuda_equals_cpu(testing::synthetic_pair("hand", 1280, 720, /*color=*/false));
  expect_cuda_equals_cpu(testing::synthetic_pair("boxes", 1280, 720, /*color=*/true));
}

}  // namespace
}  // namespace dco::gpu
