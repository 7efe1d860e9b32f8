#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cuda_device_test.hpp"
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

}  // namespace
}  // namespace dco::gpu
