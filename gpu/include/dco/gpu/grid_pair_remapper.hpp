#pragma once

#include <string>
#include <utility>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/gpu/grid_transfers.hpp"
#include "dco/gpu/remap_passes.hpp"

namespace dco::gpu {

// Rectification on a Grid (dco::PairRemapper): the rig's two fixed-point maps are uploaded once;
// per frame both raw images go up, one pass per camera interpolates them (remap_passes.hpp) and
// the rectified pair comes back. The same bytes as Rectifier's cv::remap.
template <class Grid>
class GridPairRemapper final : public PairRemapper {
 public:
  // The maps as Rectifier::table gives them; raw images are src_width x src_height.
  template <class... GridArgs>
  GridPairRemapper(RemapTable left, RemapTable right, int src_width, int src_height,
                   GridArgs&&... grid_args)
      : grid_(std::forward<GridArgs>(grid_args)...),
        src_width_(src_width),
        src_height_(src_height) {
    if (left.xy.empty() || !left.xy.same_size(right.xy) || !left.frac.same_size(left.xy) ||
        !right.frac.same_size(right.xy) || left.xy.channels != 2 || src_width <= 0 ||
        src_height <= 0)
      throw Error("rectify: the remap tables must be two non-empty maps of one size");
    width_ = left.xy.width;
    height_ = left.xy.height;
    upload_rows(grid_, left.xy, staging_xy_[0], xy_[0]);
    upload_rows(grid_, left.frac, staging_frac_[0], frac_[0]);
    upload_rows(grid_, right.xy, staging_xy_[1], xy_[1]);
    upload_rows(grid_, right.frac, staging_frac_[1], frac_[1]);
    grid_.synchronize();
  }

  void remap(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
             ImageView<std::uint8_t> left_out, ImageView<std::uint8_t> right_out) override {
    const ImageView<const std::uint8_t> in[2] = {left, right};
    const ImageView<std::uint8_t> out[2] = {left_out, right_out};
    for (int side = 0; side < 2; ++side) {
      if (!in[side].same_size(src_width_, src_height_) || !out[side].same_size(width_, height_) ||
          out[side].channels != in[side].channels)
        throw Error("rectify: the remapper's images do not have its maps' sizes");
    }
    // Both cameras are queued before anything is waited for.
    for (int side = 0; side < 2; ++side) {
      const int cn = in[side].channels;
      upload_rows(grid_, in[side], staging_in_[side], raw_[side]);
      rectified_[side].resize(static_cast<std::size_t>(width_) * height_ * cn);
      grid_.launch(
          width_, height_,
          passes::RemapBilinear{raw_[side].data(), xy_[side].data(), frac_[side].data(),
                                rectified_[side].data(), src_width_, src_height_, cn, width_});
      download_values(grid_, rectified_[side].data(), rectified_[side].size(), staging_out_[side]);
    }
    grid_.synchronize();
    for (int side = 0; side < 2; ++side) copy_rows(staging_out_[side], out[side]);
  }

 private:
  Grid grid_;
  int src_width_ = 0, src_height_ = 0, width_ = 0, height_ = 0;
  typename Grid::template Buffer<std::int16_t> xy_[2];
  typename Grid::template Buffer<std::uint16_t> frac_[2];
  typename Grid::template Buffer<std::uint8_t> raw_[2], rectified_[2];
  typename Grid::template Staging<std::int16_t> staging_xy_[2];
  typename Grid::template Staging<std::uint16_t> staging_frac_[2];
  typename Grid::template Staging<std::uint8_t> staging_in_[2], staging_out_[2];
};

}  // namespace dco::gpu
