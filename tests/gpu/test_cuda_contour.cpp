#include <gtest/gtest.h>

#include <cstdio>

#include "contour_cases.hpp"
#include "cuda_device_test.hpp"
#include "dco/gpu/backend.hpp"

namespace dco::gpu {
namespace {

class CudaContour : public testing::CudaDeviceTest {};

// The CUDA stage gives the CPU stage's bytes (tolerance: none) and prints both stage times.
TEST_F(CudaContour, FramesAreTheCpuStageBitForBit) {
  for (const testing::ContourCase& c :
       {testing::real_contour_case(testing::real_pair("Teddy", "middlebury2003/Teddy/im2.png",
                                                      "middlebury2003/Teddy/im6.png", 64)),
        testing::synthetic_contour_case("hand")}) {
    testing::expect_same_contours_as_cpu(c, [](const contour::ContourParams& params) {
      return make_cuda_contour_extractor(params);
    });
    const auto cpu = contour::make_cpu_contour_extractor({});
    const auto cuda = make_cuda_contour_extractor({});
    contour::ContourOutputs out;
    const bool neighbours = !c.before.empty();
    for (int frame = 0; frame < 3; ++frame) {
      cpu->compute(c.inputs(neighbours), out);
      cuda->compute(c.inputs(neighbours), out);
    }
    std::printf("%s: CPU %.2f ms, CUDA %.2f ms (flow on the CPU %.2f ms)\n", c.name.c_str(),
                cpu->last_timings().total_ms, cuda->last_timings().total_ms,
                cuda->last_timings().flow_ms);
  }
}

}  // namespace
}  // namespace dco::gpu
