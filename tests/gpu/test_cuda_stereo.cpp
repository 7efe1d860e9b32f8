#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cuda_device_test.hpp"
#include "dco/core/error.hpp"
#include "dco/gpu/backend.hpp"
#include "stereo_cases.hpp"

namespace dco::gpu {
namespace {

// The CUDA stage gives the CPU stage's bytes (tolerance: none) and prints both stage times.
void expect_cuda_equals_cpu(const testing::StereoCase& c) {
  testing::expect_same_as_cpu(
      c, [](const stereo::StereoParams& params) { return make_cuda_stereo_matcher(params); },
      [&c](const std::string& variant, const stereo::StereoMatcher& cuda,
           const stereo::StereoMatcher& cpu) {
        std::printf("%s, %s: CPU %.2f ms, CUDA %.2f ms (cost+aggregation+WTA %.2f ms)\n",
                    c.name.c_str(), variant.c_str(), cpu.last_timings().total_ms,
                    cuda.last_timings().total_ms, cuda.last_timings().initial_ms);
      });
}

class CudaStereo : public testing::CudaDeviceTest {};

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

// A frame too large for the device's memory fails alone: the same stage's next frame, at a size
// that fits, gives the CPU stage's bytes. Neither the failed allocation's error nor a cost table
// left half uploaded reaches it.
TEST_F(CudaStereo, AFrameTooLargeForTheDeviceLeavesTheNextOneRight) {
  testing::StereoCase c = testing::real_pair("Teddy", "middlebury2003/Teddy/im2.png",
                                             "middlebury2003/Teddy/im6.png", 256);
  c.params.internal_resolution = "full";
  c.params.search_range = "full";
  const std::unique_ptr<stereo::StereoMatcher> stage = make_cuda_stereo_matcher(c.params);
  {
    // 16384 x 16384 x 257 disparities: a cost volume of about 550 GB.
    Image<std::uint8_t> huge(16384, 16384);
    huge.fill(100);
    Image<float> out;
    EXPECT_THROW(stage->compute(huge.cview(), huge.cview(), out), Error);
  }
  const auto cpu = stereo::make_cpu_stereo_matcher(c.params);
  Image<float> expected, actual;
  cpu->compute(c.left.cview(), c.right.cview(), expected);
  stage->compute(c.left.cview(), c.right.cview(), actual);
  EXPECT_TRUE(dco::testing::same_bytes(actual.cview(), expected.cview()));
}

}  // namespace
}  // namespace dco::gpu
