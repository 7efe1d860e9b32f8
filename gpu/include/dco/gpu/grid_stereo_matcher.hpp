#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/gpu/grid_transfers.hpp"
#include "dco/gpu/stereo_passes.hpp"
#include "dco/pipeline/stereo/boundary_refinement.hpp"
#include "dco/pipeline/stereo/disparity_selection.hpp"
#include "dco/pipeline/stereo/matching_cost.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco::gpu {

// The sparse stage (dco::stereo::StereoMatcher) as a sequence of grid passes (stereo_passes.hpp)
// on a Grid: the CUDA grid on a GPU, HostGrid in tests. Same output as the CPU stage, bit for bit:
// the same integer costs, sums and decisions, in the same order. The speckle filter (a flood
// fill) runs on the host between two passes. Buffers are sized on the first frame of a geometry
// and reused; the cost volume of the whole disparity range lives on the device.
template <class Grid>
class GridStereoMatcher final : public stereo::StereoMatcher {
 public:
  template <class... GridArgs>
  explicit GridStereoMatcher(const stereo::StereoParams& params, GridArgs&&... grid_args)
      : params_(params), grid_(std::forward<GridArgs>(grid_args)...) {
    stereo::validate(params_);
    // The grid search evaluates the whole cost volume in one pass; "auto" means full here.
    if (params_.search_range == "guided" || params_.search_range == "temporal")
      throw Error("stereo.search_range = " + params_.search_range +
                  " is a CPU-backend option; use auto or full here");
    boundary_rule_ = stereo::boundary_rule(params_);
    model_ = {params_.lambda_ad, params_.lambda_census, params_.gamma_l, params_.epsilon};
  }

  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    stereo::check_stereo_input(params_, left, right);
    Stopwatch t;
    timings_ = {};
    prepare(left, right);
    grid_.synchronize();
    timings_.prepare_ms = t.lap_ms();
    arms();
    grid_.synchronize();
    timings_.arms_ms = t.lap_ms();
    search();
    grid_.synchronize();
    timings_.initial_ms = t.lap_ms();
    refine();
    grid_.synchronize();
    timings_.refine_ms = t.lap_ms();
    expand_output(left.width, left.height);
    grid_.synchronize();
    timings_.sparse_ms = t.lap_ms();
    if (stereo::refines_boundaries(params_, scale_)) {
      refine_boundaries(left.width, left.height, left.channels);
      grid_.synchronize();
      timings_.boundary_ms = t.lap_ms();
    }
    download_output(left.width, left.height, disparity);
    timings_.sparse_ms += t.lap_ms();
    timings_.total_ms = t.total_ms();
  }

  const stereo::StereoTimings& last_timings() const override { return timings_; }
  int last_scale() const override { return scale_; }
  ImageView<const std::uint8_t> internal_left_gray() const override { return grey_out_.cview(); }
  ImageView<const float> internal_raw_disparity() const override { return raw_out_.cview(); }
  ImageView<const float> internal_sparse_disparity() const override { return sparse_out_.cview(); }
  const stereo::StereoParams& params() const override { return params_; }

 private:
  template <class T>
  using Buffer = typename Grid::template Buffer<T>;
  template <class T>
  using Staging = typename Grid::template Staging<T>;

  std::size_t pixels() const { return static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_); }
  std::size_t volume_size() const { return pixels() * static_cast<std::size_t>(depth_); }

  void prepare(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right) {
    scale_ = stereo::internal_scale(params_, left.width);
    w_ = left.width / scale_;
    h_ = left.height / scale_;
    depth_ = params_.max_disparity / scale_ + 1;  // disparities 0 .. max, in internal pixels
    const int channels = left.channels;
    const bool color = channels == 3 && params_.use_color;
    const std::size_t n = pixels();

    upload_rows(grid_, left, staging_left_, input_left_);
    upload_rows(grid_, right, staging_right_, input_right_);
    const std::uint8_t* l = input_left_.data();
    const std::uint8_t* r = input_right_.data();
    if (scale_ == 2) {
      small_left_.resize(n * channels);
      small_right_.resize(n * channels);
      grid_.launch(w_, h_, passes::DownsampleHalf{l, left.width, small_left_.data(), w_, channels});
      grid_.launch(w_, h_,
                   passes::DownsampleHalf{r, left.width, small_right_.data(), w_, channels});
      l = small_left_.data();
      r = small_right_.data();
    }
    const auto [grey_l, grey_r] = grey_pair(l, r, w_, h_, channels, grey_left_, grey_right_);
    grey_for_host_ = grey_l;
    const int ad_channels = color ? 3 : 1;
    packed_left_.resize(n);
    packed_right_.resize(n);
    grid_.launch(w_, h_, passes::Pack{color ? l : grey_l, packed_left_.data(), w_, ad_channels});
    grid_.launch(w_, h_, passes::Pack{color ? r : grey_r, packed_right_.data(), w_, ad_channels});
    census_left_.resize(n);
    census_right_.resize(n);
    const int cw = params_.census_width, ch = params_.census_height;
    grid_.launch(w_, h_, passes::Census{grey_l, census_left_.data(), w_, h_, cw, ch});
    grid_.launch(w_, h_, passes::Census{grey_r, census_right_.data(), w_, h_, cw, ch});

    const int max_arm = params_.arm_max / scale_;
    if (!tables_on_device_ || tables_.channels() != ad_channels || tables_.max_arm() != max_arm) {
      // Until both tables are on the device: an allocation or copy that fails below leaves the
      // next frame to upload them again rather than read freed or null memory.
      tables_on_device_ = false;
      tables_.build(model_, ad_channels, max_arm);
      const kernels::CostTableView host = tables_.wide();
      table_ad_.resize(static_cast<std::size_t>(host.ad_size) * (max_arm + 1));
      table_census_.resize(static_cast<std::size_t>(host.census_size) * (max_arm + 1));
      grid_.upload(table_ad_.data(), host.ad, table_ad_.size() * sizeof(std::uint32_t));
      grid_.upload(table_census_.data(), host.census, table_census_.size() * sizeof(std::uint32_t));
      device_tables_ = host;
      device_tables_.ad = table_ad_.data();
      device_tables_.census = table_census_.data();
      tables_on_device_ = true;
    }
  }

  // The grey of a width x height pair: the pair itself when it is grey, else converted into
  // grey_l and grey_r.
  std::pair<const std::uint8_t*, const std::uint8_t*> grey_pair(const std::uint8_t* l,
                                                                const std::uint8_t* r, int width,
                                                                int height, int channels,
                                                                Buffer<std::uint8_t>& grey_l,
                                                                Buffer<std::uint8_t>& grey_r) {
    if (channels != 3) return {l, r};
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    grey_l.resize(n);
    grey_r.resize(n);
    grid_.launch(width, height, passes::BgrToGrey{l, grey_l.data(), width});
    grid_.launch(width, height, passes::BgrToGrey{r, grey_r.data(), width});
    return {grey_l.data(), grey_r.data()};
  }

  void arms() {
    const std::size_t n = pixels();
    for (auto* b :
         {&raw_l_, &raw_r_, &raw_u_, &raw_d_, &arm_l_, &arm_r_, &arm_u_, &arm_d_, &shortest_})
      b->resize(n);
    const kernels::ArmParams rule{params_.arm_max / scale_, params_.arm_short / scale_,
                                  params_.tau1, params_.tau2};
    grid_.launch(w_, h_,
                 passes::Arms{packed_left_.data(), w_, h_, rule, raw_l_.data(), raw_r_.data(),
                              raw_u_.data(), raw_d_.data()});
    grid_.launch(w_, h_,
                 passes::SmoothArms{raw_l_.data(), raw_r_.data(), raw_u_.data(), raw_d_.data(),
                                    arm_l_.data(), arm_r_.data(), arm_u_.data(), arm_d_.data(),
                                    shortest_.data(), w_, h_, params_.smooth_arms});
    recip_hv_.resize(n);
    recip_vh_.resize(n);
    grid_.launch(w_, h_,
                 passes::RegionReciprocals{arm_l_.data(), arm_r_.data(), arm_u_.data(),
                                           arm_d_.data(), recip_hv_.data(), recip_vh_.data(), w_});
  }

  // Region sums (means with `reciprocal`) of `in`, horizontal arms first; `in` ends up holding
  // running sums.
  void sum_horizontal_first(std::uint32_t* in, std::uint32_t* out,
                            const std::uint32_t* reciprocal) {
    grid_.launch(depth_, h_, passes::RowRunningSums{in, w_, depth_});
    grid_.launch(
        w_ * depth_, h_,
        passes::HorizontalArmSums{in, out, arm_l_.data(), arm_r_.data(), nullptr, w_, depth_});
    grid_.launch(w_ * depth_, 1, passes::ColumnRunningSums{out, w_, h_, depth_});
    grid_.launch(
        w_ * depth_, h_,
        passes::VerticalArmSums{out, in, arm_u_.data(), arm_d_.data(), reciprocal, w_, depth_});
  }
  void sum_vertical_first(std::uint32_t* in, std::uint32_t* out, const std::uint32_t* reciprocal) {
    grid_.launch(w_ * depth_, 1, passes::ColumnRunningSums{in, w_, h_, depth_});
    grid_.launch(
        w_ * depth_, h_,
        passes::VerticalArmSums{in, out, arm_u_.data(), arm_d_.data(), nullptr, w_, depth_});
    grid_.launch(depth_, h_, passes::RowRunningSums{out, w_, depth_});
    grid_.launch(
        w_ * depth_, h_,
        passes::HorizontalArmSums{out, in, arm_l_.data(), arm_r_.data(), reciprocal, w_, depth_});
  }

  void search() {
    volume_.resize(volume_size());
    scratch_volume_.resize(volume_size());
    grid_.launch(w_ * depth_, h_,
                 passes::CostVolume{packed_left_.data(), packed_right_.data(), census_left_.data(),
                                    census_right_.data(), shortest_.data(), device_tables_,
                                    volume_.data(), w_, depth_});
    // Eq. 2 over alternating pass orders; the result lands back in volume_.
    for (int pass = 0; pass < params_.aggregation_passes; ++pass) {
      if (pass % 2 == 0)
        sum_horizontal_first(volume_.data(), scratch_volume_.data(), recip_hv_.data());
      else
        sum_vertical_first(volume_.data(), scratch_volume_.data(), recip_vh_.data());
    }
    const std::size_t n = pixels();
    winner_.resize(n);
    winner_right_.resize(n);
    for (auto* b : {&best_, &second_, &below_, &above_}) b->resize(n);
    grid_.launch(w_, h_,
                 passes::WinnerLeft{volume_.data(), w_, depth_, winner_.data(), best_.data(),
                                    second_.data(), below_.data(), above_.data()});
    grid_.launch(w_, h_, passes::WinnerRight{volume_.data(), w_, depth_, winner_right_.data()});
  }

  void refine() {
    const std::size_t n = pixels();
    disp_.resize(n);
    jumped_.resize(n);
    changed_.resize(n);
    grid_.launch(w_, h_,
                 passes::Checks{winner_.data(), winner_right_.data(), best_.data(), second_.data(),
                                disp_.data(), w_, params_.lr_max_diff, params_.uniqueness > 0,
                                1.0 - params_.uniqueness});
    grid_.launch(w_, h_, passes::Fill8{changed_.data(), w_, 0});
    const kernels::pixel::VoteParams rule{params_.vote_min_count, params_.vote_min_ratio,
                                          params_.vote_tolerance, params_.vote_fill};
    for (int it = 0; it < params_.vote_iterations; ++it) {
      grid_.launch(w_ * depth_, h_,
                   passes::VoteIndicators{disp_.data(), volume_.data(), w_, depth_});
      sum_horizontal_first(volume_.data(), scratch_volume_.data(), nullptr);
      grid_.launch(
          w_, h_,
          passes::VoteApply{volume_.data(), disp_.data(), changed_.data(), w_, depth_, rule});
    }
    result_ = disp_.data();
    if (params_.max_neighbour_jump >= 0) {
      grid_.launch(
          w_, h_,
          passes::JumpCheck{disp_.data(), jumped_.data(), w_, h_, params_.max_neighbour_jump});
      result_ = jumped_.data();
    }
    if (params_.speckle_size > 0) {
      // A flood fill: on the host, between two passes.
      speckle_staging_.resize(n);
      grid_.download(speckle_staging_.data(), result_, n * sizeof(std::int16_t));
      grid_.synchronize();
      // The tight rows of the staging buffer are an image as they are.
      speckles_.apply(ImageView<std::int16_t>(speckle_staging_.data(), w_, h_, 1, w_),
                      params_.speckle_size, params_.speckle_range);
      grid_.upload(result_, speckle_staging_.data(), n * sizeof(std::int16_t));
    }
  }

  void expand_output(int width, int height) {
    const std::size_t n = pixels();
    const std::size_t full = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    raw_.resize(n);
    sparse_.resize(n);
    full_.resize(full);
    grid_.launch(w_, h_,
                 passes::Disparities{
                     winner_.data(), result_, below_.data(), best_.data(), above_.data(),
                     changed_.data(), raw_.data(), sparse_.data(), w_, params_.subpixel,
                     static_cast<float>(params_.max_disparity) / static_cast<float>(scale_)});
    grid_.launch(width, height,
                 passes::ExpandToInput{sparse_.data(), full_.data(), w_, h_, width, scale_});
  }

  void refine_boundaries(int width, int height, int channels) {
    const std::size_t n = pixels();
    side_far_.resize(n);
    side_near_.resize(n);
    const bool holes = boundary_rule_.hole_reach > kernels::pixel::kBoundaryReach;
    if (holes) {
      hole_far_.resize(n);
      hole_near_.resize(n);
    }
    float* hole_far = holes ? hole_far_.data() : side_far_.data();
    float* hole_near = holes ? hole_near_.data() : side_near_.data();
    grid_.launch(w_, h_,
                 passes::BoundarySides{sparse_.data(), side_far_.data(), side_near_.data(),
                                       hole_far, hole_near, w_, h_, boundary_rule_.hole_reach});
    const auto [l, r] = grey_pair(input_left_.data(), input_right_.data(), width, height, channels,
                                  full_grey_left_, full_grey_right_);
    grid_.launch(
        width, height,
        passes::RefineBoundary{l, r, side_far_.data(), side_near_.data(), hole_far, hole_near,
                               full_.data(), w_, h_, width, height, scale_, boundary_rule_});
  }

  void download_output(int width, int height, Image<float>& disparity) {
    const std::size_t n = pixels();
    const std::size_t full = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    download_values(grid_, full_.data(), full, staging_full_);
    download_values(grid_, raw_.data(), n, staging_raw_);
    download_values(grid_, sparse_.data(), n, staging_sparse_);
    download_values(grid_, grey_for_host_, n, staging_grey_);
    grid_.synchronize();
    copy_rows(staging_full_, width, height, disparity);
    copy_rows(staging_raw_, w_, h_, raw_out_);
    copy_rows(staging_sparse_, w_, h_, sparse_out_);
    copy_rows(staging_grey_, w_, h_, grey_out_);
  }

  stereo::StereoParams params_;
  Grid grid_;
  stereo::CostModel model_;
  kernels::pixel::BoundaryRule boundary_rule_;
  stereo::CostTables tables_;
  kernels::CostTableView device_tables_;
  bool tables_on_device_ = false;
  stereo::StereoTimings timings_;
  int scale_ = 1, w_ = 0, h_ = 0, depth_ = 1;

  Staging<std::uint8_t> staging_left_, staging_right_, staging_grey_;
  Staging<std::int16_t> speckle_staging_;
  Staging<float> staging_full_, staging_raw_, staging_sparse_;
  Buffer<std::uint8_t> input_left_, input_right_, small_left_, small_right_, grey_left_,
      grey_right_, full_grey_left_, full_grey_right_;
  const std::uint8_t* grey_for_host_ = nullptr;
  Buffer<std::uint32_t> packed_left_, packed_right_, table_ad_, table_census_;
  Buffer<std::uint64_t> census_left_, census_right_;
  Buffer<std::uint8_t> raw_l_, raw_r_, raw_u_, raw_d_, arm_l_, arm_r_, arm_u_, arm_d_, shortest_;
  Buffer<std::uint32_t> recip_hv_, recip_vh_, volume_, scratch_volume_;
  Buffer<std::int16_t> winner_, winner_right_, disp_, jumped_;
  std::int16_t* result_ = nullptr;  // the checked map: disp_ or, after the jump check, jumped_
  Buffer<std::uint16_t> best_, second_, below_, above_;
  Buffer<std::uint8_t> changed_;
  Buffer<float> raw_, sparse_, full_, side_far_, side_near_, hole_far_, hole_near_;
  stereo::SpeckleFilter speckles_;
  Image<std::uint8_t> grey_out_;
  Image<float> raw_out_, sparse_out_;
};

}  // namespace dco::gpu
