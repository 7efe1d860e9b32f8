#include "cuda_entry.hpp"
#include "cuda_grid.cuh"
#include "dco/gpu/grid_photometric_refiner.hpp"
#include "dco/gpu/grid_system_solver.hpp"

namespace dco::gpu::detail {

std::unique_ptr<densify::SystemSolver> cuda_densify_solver(const densify::DensifyParams& params) {
  return std::make_unique<GridSystemSolver<CudaGrid>>(params);
}

std::unique_ptr<densify::PhotometricRefinement> cuda_photometric_refinement() {
  return std::make_unique<GridPhotometricRefiner<CudaGrid>>();
}

}  // namespace dco::gpu::detail
