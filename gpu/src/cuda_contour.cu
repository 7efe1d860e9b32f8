#include "cuda_entry.hpp"
#include "cuda_grid.cuh"
#include "dco/gpu/grid_contour_extractor.hpp"

namespace dco::gpu::detail {

std::unique_ptr<contour::ContourExtractor> cuda_contour_extractor(
    const contour::ContourParams& params) {
  return std::make_unique<GridContourExtractor<CudaGrid>>(params);
}

}  // namespace dco::gpu::detail
