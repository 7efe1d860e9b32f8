#pragma once

#include <cstdint>
#include <cstring>
#include <utility>

#include "dco/core/image.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/gpu/contour_passes.hpp"
#include "dco/gpu/grid_transfers.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/contour/flow_cue.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"

namespace dco::gpu {

// The contour stage (dco::contour::ContourExtractor) with its image side on a Grid: the stereo
// cue and its box filter, the Gaussian, the Sobel gradient and the gated Canny classification
// run as passes (contour_passes.hpp). The flow cue (DIS optical flow and the fusion of its two
// fields) runs on the CPU while the grid blurs and differentiates the image, and its M_fuse is
// uploaded; the hysteresis (a flood fill) runs on the host on the downloaded classes. Same output
// as the CPU stage, bit for bit. Timings: gaussian_ms is the host's time queueing the blur and
// gradient plus what they still took once the flow was done (on a GPU, about 0 when they finish
// during it).
template <class Grid>
class GridContourExtractor final : public contour::ContourExtractor {
 public:
  template <class... GridArgs>
  explicit GridContourExtractor(const contour::ContourParams& params, GridArgs&&... grid_args)
      : params_(params), flow_cue_(params), grid_(std::forward<GridArgs>(grid_args)...) {
    contour::validate(params_);
    levels_ = {static_cast<float>(params_.t_low), static_cast<float>(params_.t_high),
               static_cast<float>(params_.t_depth)};
  }

  void compute(const contour::ContourInputs& in, contour::ContourOutputs& out) override {
    contour::check_contour_input(params_, in);
    const bool flow = params_.use_flow && !in.neighbour_a.empty() && !in.neighbour_b.empty();
    const bool given_flow = !in.flow_cue.empty();
    // Also on a sequence's first frames, which have no flow yet: a frame too small for DIS fails
    // there, before any output, not two frames later.
    if (params_.use_flow && !given_flow) flow_cue_.check_size(in.centre);
    Stopwatch t;
    timings_ = {};
    const int cw = in.centre.width, ch = in.centre.height;
    const int iw = in.image.width, ih = in.image.height;
    const std::size_t internal = static_cast<std::size_t>(cw) * static_cast<std::size_t>(ch);
    const std::size_t full = static_cast<std::size_t>(iw) * static_cast<std::size_t>(ih);
    const bool given_gradients = !in.m_intensity.empty();
    out.m_fuse.resize(cw, ch);
    if (!given_gradients) out.m_intensity.resize(iw, ih);
    out.contours.resize(iw, ih);

    classes_.resize(full);
    if (given_gradients) {
      upload_rows(grid_, in.m_intensity, staging_magnitude_, magnitude_);
      upload_rows(grid_, in.direction, staging_direction_, direction_);
    } else {
      // The blur and the gradient need nothing of the cues: they are queued first, so a GPU
      // computes them while the CPU runs the optical flow.
      image_.resize(full);
      for (auto* b : {&blur_tmp_, &blurred_, &magnitude_}) b->resize(full);
      direction_.resize(full);
      upload_rows(grid_, in.image, staging_image_, image_);
      passes::GaussianVertical vertical{image_.data(), blur_tmp_.data(), iw, ih, {}};
      passes::GaussianHorizontal horizontal{blur_tmp_.data(), blurred_.data(), iw, {}};
      const auto& taps = contour::gaussian5_taps();
      for (int k = 0; k < 5; ++k) vertical.taps[k] = horizontal.taps[k] = taps[k];
      grid_.launch(iw, ih, vertical);
      grid_.launch(iw, ih, horizontal);
      grid_.launch(iw, ih,
                   passes::Sobel{blurred_.data(), magnitude_.data(), direction_.data(), iw, ih,
                                 1.0f / contour::kMaxSobelMagnitude8Bit});
    }
    timings_.gaussian_ms = t.lap_ms();

    fuse_.resize(internal);
    const bool stereo = params_.use_stereo && (!in.disparity.empty() || !in.stereo_cue.empty());
    if (given_flow) {
      upload_rows(grid_, in.flow_cue, staging_fuse_, fuse_);
    } else if (flow) {
      flow_cue_.compute(in, out.m_fuse.view(), timings_, t);
      upload_rows(grid_, out.m_fuse.cview(), staging_fuse_, fuse_);
    } else if (!stereo) {
      grid_.launch(cw, ch, passes::FillFloat{fuse_.data(), cw, 0.0f});
    }
    // What the blur and gradient (or the upload of the given ones) still took after the flow.
    grid_.synchronize();
    timings_.gaussian_ms += t.lap_ms();
    if (stereo) {
      for (auto* b : {&disparity_, &jumps_, &tmp_, &cue_}) b->resize(internal);
      if (!in.stereo_cue.empty()) {
        upload_rows(grid_, in.stereo_cue, staging_disparity_, flow ? cue_ : fuse_);
      } else {
        upload_rows(grid_, in.disparity, staging_disparity_, disparity_);
        const float inv_jump = 1.0f / static_cast<float>(params_.stereo_jump);
        grid_.launch(cw, ch,
                     passes::JumpStrength{disparity_.data(), jumps_.data(), cw, ch, inv_jump});
        box(jumps_.data(), flow ? cue_.data() : fuse_.data(), cw, ch);
      }
      if (flow) grid_.launch(cw, ch, passes::MaxInto{cue_.data(), fuse_.data(), cw});
      grid_.synchronize();
      timings_.stereo_cue_ms = t.lap_ms();
    }

    grid_.launch(iw, ih,
                 passes::CannyClassify{magnitude_.data(), direction_.data(), fuse_.data(), iw, ih,
                                       cw, ch, levels_, classes_.data()});
    download_values(grid_, fuse_.data(), internal, staging_fuse_);
    if (!given_gradients) download_values(grid_, magnitude_.data(), full, staging_magnitude_);
    download_values(grid_, classes_.data(), full, staging_classes_);
    grid_.synchronize();
    copy_rows(staging_fuse_, cw, ch, out.m_fuse);
    if (!given_gradients) copy_rows(staging_magnitude_, iw, ih, out.m_intensity);
    copy_rows(staging_classes_, iw, ih, out.contours);
    contour::canny_hysteresis(out.contours.view(), canny_);
    timings_.canny_ms = t.lap_ms();
    timings_.total_ms = t.total_ms();
  }

  const contour::ContourTimings& last_timings() const override { return timings_; }

  // The flow cue is the CPU's (DIS and its fusion): the same steps as the CPU stage's.
  void flow_cue(const contour::ContourInputs& in, Image<float>& out,
                contour::ContourTimings& timings) override {
    flow_cue_.compute_alone(in, out, timings);
  }

 private:
  template <class T>
  using Buffer = typename Grid::template Buffer<T>;
  template <class T>
  using Staging = typename Grid::template Staging<T>;

  // The mean box filter of the configured size from `in` into `out` (both internal size).
  void box(const float* in, float* out, int w, int h) {
    const int size = params_.box_size;
    const float inv = 1.0f / static_cast<float>(size);
    grid_.launch(w, h, passes::BoxVertical{in, tmp_.data(), w, h, size, inv});
    grid_.launch(w, h, passes::BoxHorizontal{tmp_.data(), out, w, size, inv});
  }

  contour::ContourParams params_;
  kernels::CannyLevels levels_;
  contour::FlowCue flow_cue_;
  Grid grid_;
  contour::CannyScratch canny_;
  contour::ContourTimings timings_;
  Staging<std::uint8_t> staging_image_, staging_classes_, staging_direction_;
  Staging<float> staging_fuse_, staging_disparity_, staging_magnitude_;
  Buffer<std::uint8_t> image_, direction_, classes_;
  Buffer<float> fuse_, disparity_, jumps_, tmp_, cue_, blur_tmp_, blurred_, magnitude_;
};

}  // namespace dco::gpu
