#include "cuda_entry.hpp"
#include "cuda_grid.cuh"
#include "dco/gpu/grid_pair_remapper.hpp"

namespace dco::gpu::detail {

std::unique_ptr<PairRemapper> cuda_pair_remapper(const Rectifier& rectifier) {
  return std::make_unique<GridPairRemapper<CudaGrid>>(rectifier.table(true), rectifier.table(false),
                                                      rectifier.input_width(),
                                                      rectifier.input_height());
}

}  // namespace dco::gpu::detail
