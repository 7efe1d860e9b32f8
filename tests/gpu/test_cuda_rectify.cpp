#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cuda_device_test.hpp"
#include "dco/gpu/backend.hpp"
#include "remap_cases.hpp"

namespace dco::gpu {
namespace {

class CudaRectify : public testing::CudaDeviceTest {};

// The CUDA remapper gives cv::remap's bytes (tolerance: none) and prints both times per pair.
TEST_F(CudaRectify, RigsAreTheCpuRectifierBitForBit) {
  testing::expect_rigs_rectify_as_cpu(
      [](const Rectifier& r) { return make_cuda_pair_remapper(r); },
      [](const std::string& name, double cpu_ms, double cuda_ms) {
        std::printf("%s: CPU %.2f ms, CUDA %.2f ms per pair (with transfers)\n", name.c_str(),
                    cpu_ms, cuda_ms);
      });
}

}  // namespace
}  // namespace dco::gpu
