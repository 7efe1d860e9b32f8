#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>

#include "dco/core/image.hpp"
#include "dco/gpu/grid_transfers.hpp"
#include "dco/gpu/photometric_passes.hpp"
#include "dco/pipeline/densify/photometric_refiner.hpp"

namespace dco::gpu {

// The densifier's photometric refinement (densify::PhotometricRefinement) on a Grid, in the plain
// order that defines it: both images' derivative planes once, then per iteration every pixel's
// terms, the edges, the inverse diagonals and each half-sweep as one pass over the image, the
// clamp last. Uploads the two images and the map, downloads the map: the CPU refiner's bits.
// Device buffers are sized on a geometry's first frame and reused.
template <class Grid>
class GridPhotometricRefiner final : public densify::PhotometricRefinement {
 public:
  template <class... GridArgs>
  explicit GridPhotometricRefiner(GridArgs&&... grid_args)
      : grid_(std::forward<GridArgs>(grid_args)...) {}

  // Every frame: photometric_max_pixels is the CPU's time budget, and on a GPU a 1280x720 frame
  // takes 1.8 ms (H200, transfers included).
  bool refines(const densify::PhotometricParams& params, int width, int height) const override {
    return params.iterations > 0 && width > 0 && height > 0;
  }

 protected:
  void fit(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
           const densify::PhotometricParams& params, ImageView<float> disparity) override {
    const int w = disparity.width, h = disparity.height;
    const std::size_t n = static_cast<std::size_t>(w) * h;
    upload_rows(grid_, left, image_staging_[0], left_);
    upload_rows(grid_, right, image_staging_[1], right_);
    upload_rows(grid_, ImageView<const float>(disparity), map_staging_, d_);
    for (auto* b : {&a_, &rhs_, &smooth_, &wx_, &wy_, &inverse_diagonal_}) b->resize(n);
    passes::DerivativePlanes planes[2];
    for (int i = 0; i < 2; ++i)
      for (int k = 0; k < 6; ++k) {
        derivatives_[i][k].resize(n);
        planes[i].plane[k] = derivatives_[i][k].data();
      }
    grid_.launch(w, h, passes::PhotometricDerivatives{left_.data(), w, h, planes[0]});
    grid_.launch(w, h, passes::PhotometricDerivatives{right_.data(), w, h, planes[1]});
    const kernels::pixel::PhotometricWeights weights{static_cast<float>(params.alpha),
                                                     static_cast<float>(params.delta),
                                                     static_cast<float>(params.gamma)};
    const passes::CouplingPlanes couplings{
        a_.data(), smooth_.data(), wx_.data(), wy_.data(), inverse_diagonal_.data(), w, h};
    for (int iteration = 0; iteration < params.iterations; ++iteration) {
      grid_.launch(w, h,
                   passes::PhotometricTerms{planes[0], planes[1], d_.data(), w, h, weights,
                                            a_.data(), rhs_.data(), smooth_.data()});
      grid_.launch(w, h, passes::PhotometricEdges{couplings});
      grid_.launch(w, h, passes::PhotometricInverseDiagonal{couplings});
      for (int half = 0; half < 2 * params.sweeps; ++half)
        grid_.launch((w + 1) / 2, h,
                     passes::PhotometricSorColour{rhs_.data(), inverse_diagonal_.data(), wx_.data(),
                                                  wy_.data(), d_.data(), w, h, half & 1,
                                                  densify::kPhotometricOmega});
    }
    grid_.launch(w, h, passes::ClampBelowZero{d_.data(), w});
    // The map's staging buffer is free again: the download is queued after its upload.
    download_values(grid_, static_cast<const float*>(d_.data()), n, map_staging_);
    grid_.synchronize();
    copy_rows(map_staging_, disparity);
  }

 private:
  template <class T>
  using Buffer = typename Grid::template Buffer<T>;
  template <class T>
  using Staging = typename Grid::template Staging<T>;

  Grid grid_;
  Buffer<std::uint8_t> left_, right_;
  Buffer<float> derivatives_[2][6];  // the left image's planes, then the right's
  Buffer<float> d_, a_, rhs_, smooth_, wx_, wy_, inverse_diagonal_;
  Staging<std::uint8_t> image_staging_[2];
  Staging<float> map_staging_;
};

}  // namespace dco::gpu
