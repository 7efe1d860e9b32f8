#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "cuda_device_test.hpp"
#include "dco/gpu/backend.hpp"
#include "densify_cases.hpp"
#include "photometric_cases.hpp"

namespace dco::gpu {
namespace {

class CudaPhotometric : public testing::CudaDeviceTest {};

// The CUDA refinement gives the CPU refiner's bytes (tolerance: none) on 640x360 and 1280x720
// frames (the latter refined here although the defaults skip that size on the CPU) and prints
// both times.
TEST_F(CudaPhotometric, DenseFramesAreTheCpuRefinementBitForBit) {
  densify::PhotometricParams every_size;
  every_size.max_pixels = 100000000;
  for (const auto& [w, h] : {std::pair{640, 360}, std::pair{1280, 720}})
    testing::expect_same_refinement_as_cpu(
        testing::densify_frames("hand", w, h, every_size),
        [] { return make_cuda_photometric_refinement(); },
        [w = w, h = h](const std::string& variant, const densify::Densifier& cpu,
                       const densify::Densifier& cuda) {
          std::printf("%dx%d %s: CPU refinement %.2f ms, CUDA refinement %.2f ms\n", w, h,
                      variant.c_str(), cpu.last_timings().refine_ms, cuda.last_timings().refine_ms);
        });
}

TEST_F(CudaPhotometric, OddSizesAndValuesBelowZeroAreTheCpuRefinersBits) {
  testing::expect_same_maps_as_cpu_refiner([] { return make_cuda_photometric_refinement(); });
}

}  // namespace
}  // namespace dco::gpu
