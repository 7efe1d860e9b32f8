#include <cuda_runtime.h>

#include <string>

#include "cuda_entry.hpp"
#include "cuda_grid.cuh"
#include "dco/gpu/grid_stereo_matcher.hpp"

namespace dco::gpu::detail {
namespace {

__global__ void probe_kernel() {}

}  // namespace

CudaDevice cuda_probe() {
  CudaDevice d;
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess) {
    d.why = cudaGetErrorString(status);
    return d;
  }
  if (count == 0) {
    d.why = "the CUDA runtime sees no device";
    return d;
  }
  cudaDeviceProp p{};
  const cudaError_t props = cudaGetDeviceProperties(&p, 0);
  if (props != cudaSuccess) {
    d.why = cudaGetErrorString(props);
    return d;
  }
  d.name = p.name;
  d.compute_major = p.major;
  d.compute_minor = p.minor;
  d.memory_gib = static_cast<double>(p.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0);
  // A device older than every architecture this build holds code for has no kernel to run:
  // "auto" must then stay on the CPU instead of failing at the first frame.
  cudaFuncAttributes attributes{};
  if (const cudaError_t image = cudaFuncGetAttributes(&attributes, probe_kernel);
      image != cudaSuccess) {
    (void)cudaGetLastError();
    d.why = std::string("no kernel of this build runs on ") + p.name + " (compute capability " +
            std::to_string(p.major) + "." + std::to_string(p.minor) +
            "): " + cudaGetErrorString(image);
    return d;
  }
  d.usable = true;
  return d;
}

std::unique_ptr<stereo::StereoMatcher> cuda_stereo_matcher(const stereo::StereoParams& params) {
  return std::make_unique<GridStereoMatcher<CudaGrid>>(params);
}

}  // namespace dco::gpu::detail
