#include "cuda_entry.hpp"
#include "cuda_grid.cuh"
#include "dco/gpu/grid_system_solver.hpp"

namespace dco::gpu::detail {

std::unique_ptr<densify::SystemSolver> cuda_densify_solver(const densify::DensifyParams& params) {
  return std::make_unique<GridSystemSolver<CudaGrid>>(params);
}

}  // namespace dco::gpu::detail
