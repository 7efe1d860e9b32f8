#include <gtest/gtest.h>

#include <cstdio>

#include "cuda_device_test.hpp"
#include "dco/gpu/backend.hpp"
#include "densify_cases.hpp"

namespace dco::gpu {
namespace {

class CudaDensify : public testing::CudaDeviceTest {};

// The CUDA solver gives the CPU solver's bytes (tolerance: none) and prints both solve times.
TEST_F(CudaDensify, HeadsetFramesAreTheCpuSolverBitForBit) {
  testing::expect_same_dense_as_cpu(
      testing::densify_frames("hand", 1280, 720),
      [](const densify::DensifyParams& p) { return make_cuda_densify_solver(p); },
      [](const std::string& variant, const densify::Densifier& cpu,
         const densify::Densifier& cuda) {
        std::printf("%s: CPU solve %.2f ms, CUDA solve %.2f ms (%d iterations)\n", variant.c_str(),
                    cpu.last_timings().solve_ms, cuda.last_timings().solve_ms,
                    cuda.last_report().iterations);
      });
}

}  // namespace
}  // namespace dco::gpu
