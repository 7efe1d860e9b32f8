#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dco/core/error.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"
#include "dco/pipeline/row_team.hpp"
#include "dco/pipeline/stereo/boundary_refinement.hpp"
#include "dco/pipeline/stereo/census.hpp"
#include "dco/pipeline/stereo/cross_aggregation.hpp"
#include "dco/pipeline/stereo/cross_arms.hpp"
#include "dco/pipeline/stereo/disparity_search.hpp"
#include "dco/pipeline/stereo/disparity_selection.hpp"
#include "dco/pipeline/stereo/histogram_vote.hpp"
#include "dco/pipeline/stereo/image_ops.hpp"
#include "dco/pipeline/stereo/matching_cost.hpp"
#include "dco/pipeline/stereo/search_guide.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco::stereo {
namespace {

std::string size_text(ImageView<const std::uint8_t> v) {
  return std::to_string(v.width) + "x" + std::to_string(v.height) + "x" +
         std::to_string(v.channels);
}

// dst[2 x] = dst[2 x + 1] = scale * src[x] for x < count: a half-size row at input size,
// written per pair so that it vectorises.
void spread_pairs(const float* __restrict src, int count, float scale, float* __restrict dst) {
  for (int x = 0; x < count; ++x) {
    const float v = scale * src[x];
    dst[2 * x] = v;
    dst[2 * x + 1] = v;
  }
}

class CpuStereoMatcher final : public StereoMatcher {
  // A pass of the search guide and the map it leaves.
  struct CoarsePass {
    std::unique_ptr<StereoMatcher> matcher;
    int scale = 0;  // the internal scale it was made for
    Image<float> disparity;
  };

 public:
  // `team` shares the stage's row-wise steps (a stage's guide pass uses the stage's); without
  // one the matcher starts its own, of stereo.row_threads threads.
  explicit CpuStereoMatcher(const StereoParams& params, pipeline::RowTeam* team = nullptr)
      : params_(params), team_(team) {
    validate(params_);
    if (team_ == nullptr) {
      own_team_ =
          std::make_unique<pipeline::RowTeam>(pipeline::RowTeam::threads_for(params_.row_threads));
      team_ = own_team_.get();
    }
    boundary_rule_ = boundary_rule(params_);
    model_ = {params_.lambda_ad, params_.lambda_census, params_.gamma_l, params_.epsilon};
    vote_ = {params_.vote_iterations, params_.vote_min_count, params_.vote_min_ratio,
             params_.vote_tolerance, params_.vote_fill};
  }

  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    check_stereo_input(params_, left, right);
    // Cleared first, so that a frame that fails part-way leaves no previous map behind.
    const bool had_previous = has_previous_;
    has_previous_ = false;
    Stopwatch t;
    timings_ = {};

    prepare(left, right);
    const bool previous =
        had_previous && values_.cview().same_size(w_, h_) && previous_max_d_ == max_d_;
    timings_.prepare_ms = t.lap_ms();

    // Arm lengths are given in input pixels; the windows cover the same scene area at any
    // internal resolution.
    const ArmRule rule{params_.arm_max / scale_, params_.arm_short / scale_, params_.tau1,
                       params_.tau2};
    if (ad_left_.channels == 1)
      compute_grey_cross_arms(ad_left_, rule, arms_);
    else
      compute_cross_arms(packed_left_.cview(), rule, arms_);
    if (params_.smooth_arms) smooth_cross_arms(arms_, arm_scratch_);
    shortest_arm_.resize(w_, h_);
    for (int y = 0; y < h_; ++y) shortest_arm_row(arms_, y, shortest_arm_.row(y));
    regions_.build(arms_, agg_scratch_, params_.aggregation_passes);
    timings_.arms_ms = t.lap_ms();

    const bool guided = guide_search(previous);
    timings_.guide_ms = t.since_lap_ms();
    timings_.searched_fraction = guided ? mask_.searched_fraction() : 1.0;
    wta_.reset(w_, h_);
    const MatchingImages images{packed_left_.cview(), packed_right_.cview(), census_left_.cview(),
                                census_right_.cview(), shortest_arm_.cview()};
    search_.run(images, tables_, regions_, params_.aggregation_passes, max_d_, wta_,
                guided ? &mask_ : nullptr, team_);
    timings_.initial_ms = t.lap_ms();

    disp_.resize(w_, h_);
    disp_.copy_from(wta_.left_disparity());
    left_right_check(disp_.view(), wta_.right_disparity(), params_.lr_max_diff, lr_scratch_);
    if (params_.uniqueness > 0)
      uniqueness_check(disp_.view(), wta_.best_cost(), wta_.second_cost(), params_.uniqueness);
    changed_.resize(w_, h_);
    histogram_vote(disp_.view(), max_d_, regions_, vote_, vote_scratch_, changed_.view());
    if (params_.max_neighbour_jump >= 0)
      discontinuity_check(disp_.view(), params_.max_neighbour_jump, jump_scratch_);
    if (params_.speckle_size > 0)
      speckles_.apply(disp_.view(), params_.speckle_size, params_.speckle_range);
    timings_.refine_ms = t.lap_ms();

    write_output(left.width, left.height, disparity);
    timings_.sparse_ms = t.lap_ms();

    if (refines_boundaries(params_, scale_)) {
      refine_boundaries(left, right, disparity);
      timings_.boundary_ms = t.lap_ms();
    }
    timings_.total_ms = t.total_ms();
    has_previous_ = true;
    previous_max_d_ = max_d_;
  }

  void reset() override { has_previous_ = false; }

  const StereoTimings& last_timings() const override { return timings_; }
  int last_scale() const override { return scale_; }
  ImageView<const std::uint8_t> internal_left_gray() const override { return census_gray_left_; }
  ImageView<const float> internal_raw_disparity() const override { return raw_.view(); }
  ImageView<const float> internal_sparse_disparity() const override { return values_.view(); }
  const StereoParams& params() const override { return params_; }

 private:
  // Which disparity batches each tile of each internal row searches (search_guide.hpp), from a
  // pass of this stage at half the internal size or, with "temporal" and the previous frame's
  // map at hand, from that map and a pass at a quarter of the size. False: search them all.
  bool guide_search(bool previous) {
    if (params_.search_range == "full") return false;
    // Up to four batches the half-size pass costs about what it saves (street scenes at
    // 96 px search about three quarters of their batches even when guided).
    if (params_.search_range == "auto" && max_d_ + 1 <= 4 * DisparitySearch::kBatch) return false;
    const bool temporal = params_.search_range == "temporal" || params_.search_range == "auto";
    if (temporal && previous && guide_from_previous()) return true;
    if (!coarse_pass(half_, 2)) return false;
    guide_batches(half_.disparity.cview(), w_, h_, max_d_, GuideRule{DisparitySearch::kBatch},
                  guide_scratch_, mask_);
    return true;
  }

  // The previous frame's map (which values_ still holds) tells where the surfaces were: each
  // tile searches the batches within kPreviousMargin of its values. A quarter-size pass adds the
  // batches of what has come into view since (its margin covers its coarser values); it misses
  // thin objects on their own, which the half-size pass of a frame without a previous map finds.
  bool guide_from_previous() {
    if (!coarse_pass(quarter_, 4)) return false;
    GuideRule quarter{DisparitySearch::kBatch};
    quarter.scale = 4;
    quarter.margin = kQuarterMargin;
    // Only the batches of its own values: where it has few, the previous frame's map decides
    // (with its fallbacks to the row's or every batch). With fallbacks of its own it added
    // twice as much to the search and found no more (bench/RESULTS.md).
    quarter.min_valid = 0;
    quarter.tile_min_valid = 0;
    guide_batches(quarter_.disparity.cview(), w_, h_, max_d_, quarter, guide_scratch_, mask_);
    previous_half_.resize(w_ / 2, h_ / 2);
    halve_sparse_map(values_.cview(), previous_half_.view());
    GuideRule previous{DisparitySearch::kBatch};
    previous.margin = kPreviousMargin;
    guide_batches(previous_half_.cview(), w_, h_, max_d_, previous, guide_scratch_, previous_mask_);
    mask_.merge(previous_mask_);
    return true;
  }

  // This stage, searching every disparity, on the internal images shrunk `factor` times (2 or 4:
  // halved once or twice), into pass.disparity. False where the shrunk images are too small.
  bool coarse_pass(CoarsePass& pass, int factor) {
    const int cw = w_ / factor, ch = h_ / factor;
    const int coarse_max = (max_d_ + 1) / factor;
    // Too small for a pass of its own: the full search is cheap there anyway.
    if (coarse_max < 1 || coarse_max >= cw || cw < params_.census_width ||
        ch < params_.census_height)
      return false;
    if (!pass.matcher || pass.matcher->params().max_disparity != coarse_max ||
        pass.scale != scale_) {
      StereoParams p = params_;
      p.search_range = "full";
      p.internal_resolution = "full";
      p.max_disparity = coarse_max;
      p.arm_max = std::max(2, params_.arm_max / (factor * scale_));
      p.arm_short = std::min(p.arm_max, params_.arm_short / (factor * scale_));
      pass.matcher = std::make_unique<CpuStereoMatcher>(p, team_);
      pass.scale = scale_;
    }
    halves_[0].resize(w_ / 2, h_ / 2, internal_left_.channels);
    halves_[1].resize(w_ / 2, h_ / 2, internal_right_.channels);
    downsample_half(internal_left_, halves_[0].view());
    downsample_half(internal_right_, halves_[1].view());
    ImageView<const std::uint8_t> l = halves_[0].cview(), r = halves_[1].cview();
    if (factor == 4) {
      quarters_[0].resize(cw, ch, internal_left_.channels);
      quarters_[1].resize(cw, ch, internal_right_.channels);
      downsample_half(l, quarters_[0].view());
      downsample_half(r, quarters_[1].view());
      l = quarters_[0].cview();
      r = quarters_[1].cview();
    }
    pass.matcher->compute(l, r, pass.disparity);
    return true;
  }

  void prepare(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right) {
    scale_ = internal_scale(params_, left.width);
    w_ = left.width / scale_;
    h_ = left.height / scale_;
    // Rounded down, so the search never goes beyond max_disparity input pixels.
    max_d_ = params_.max_disparity / scale_;
    const bool color = left.channels == 3 && params_.use_color;

    ImageView<const std::uint8_t> l = left, r = right;
    if (scale_ == 2) {
      small_left_.resize(w_, h_, left.channels);
      small_right_.resize(w_, h_, left.channels);
      l = small_left_.view();
      r = small_right_.view();
    }
    internal_left_ = l;
    internal_right_ = r;
    if (left.channels == 3) {
      gray_left_.resize(w_, h_);
      gray_right_.resize(w_, h_);
    }
    const ImageView<const std::uint8_t> gl = left.channels == 3 ? gray_left_.cview() : l;
    census_gray_left_ = gl;
    const ImageView<const std::uint8_t> gr = left.channels == 3 ? gray_right_.cview() : r;
    ad_left_ = color ? l : gl;
    ad_right_ = color ? r : gr;
    packed_left_.resize(w_, h_);
    packed_right_.resize(w_, h_);
    census_left_.resize(w_, h_);
    census_right_.resize(w_, h_);

    // Row by row: an internal row needs its two input rows; the census, the grey rows within
    // its window, so it waits for every block.
    team_->run(h_, [&](int, int begin, int end) {
      const int n = end - begin;
      if (scale_ == 2) {
        downsample_half(left.sub(0, 2 * begin, left.width, 2 * n),
                        small_left_.view().sub(0, begin, w_, n));
        downsample_half(right.sub(0, 2 * begin, right.width, 2 * n),
                        small_right_.view().sub(0, begin, w_, n));
      }
      if (left.channels == 3) {
        bgr_to_gray(l.sub(0, begin, w_, n), gray_left_.view().sub(0, begin, w_, n));
        bgr_to_gray(r.sub(0, begin, w_, n), gray_right_.view().sub(0, begin, w_, n));
      }
      for (int y = begin; y < end; ++y) {
        kernels::pack_pixels(ad_left_.row(y), ad_left_.channels, w_, packed_left_.row(y));
        kernels::pack_pixels(ad_right_.row(y), ad_right_.channels, w_, packed_right_.row(y));
      }
    });
    team_->run(h_, [&](int, int begin, int end) {
      census_transform_rows(gl, params_.census_width, params_.census_height, begin, end,
                            census_left_.view());
      census_transform_rows(gr, params_.census_width, params_.census_height, begin, end,
                            census_right_.view());
    });

    if (tables_.channels() != ad_left_.channels || tables_.max_arm() != params_.arm_max / scale_)
      tables_.build(model_, ad_left_.channels, params_.arm_max / scale_);
  }

  void refine_boundaries(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                         Image<float>& disparity) {
    ImageView<const std::uint8_t> l = left, r = right;
    if (left.channels == 3) {
      full_grey_left_.resize(left.width, left.height);
      full_grey_right_.resize(right.width, right.height);
      bgr_to_gray(left, full_grey_left_.view());
      bgr_to_gray(right, full_grey_right_.view());
      l = full_grey_left_.cview();
      r = full_grey_right_.cview();
    }
    boundaries_.apply(values_.cview(), l, r, scale_, boundary_rule_, disparity.view(), team_);
  }

  void write_output(int width, int height, Image<float>& disparity) {
    disparity.resize(width, height);
    // Value of every internal pixel first (internal pixels), then nearest-neighbour expansion to
    // input size (input pixels).
    values_.resize(w_, h_);
    raw_.resize(w_, h_);
    const float max_value = static_cast<float>(params_.max_disparity) / static_cast<float>(scale_);
    // The fit may lean past the searched range by less than a pixel; values stay inside it.
    for (int y = 0; y < h_; ++y) {
      const kernels::DisparityRowInputs in{wta_.left_disparity().row(y),
                                           disp_.row(y),
                                           changed_.row(y),
                                           wta_.cost_below().row(y),
                                           wta_.best_cost().row(y),
                                           wta_.cost_above().row(y)};
      kernels::disparity_values_row(in, w_, params_.subpixel, max_value, raw_.row(y),
                                    values_.row(y));
    }
    // Each internal row once, then copies for the input rows that repeat it.
    const auto scale = static_cast<float>(scale_);
    for (int y = 0; y < height; ++y) {
      float* dst = disparity.row(y);
      const int source = std::min(y / scale_, h_ - 1);
      if (y > 0 && source == std::min((y - 1) / scale_, h_ - 1)) {
        std::copy(disparity.row(y - 1), disparity.row(y - 1) + width, dst);
        continue;
      }
      const float* src = values_.row(source);
      const int whole = std::min(w_, width / scale_);  // internal columns with all copies inside
      if (scale_ == 2)
        spread_pairs(src, whole, scale, dst);
      else
        for (int x = 0; x < whole; ++x)
          for (int k = 0; k < scale_; ++k) dst[x * scale_ + k] = scale * src[x];
      for (int x = whole * scale_; x < width; ++x)
        dst[x] = scale * src[std::min(x / scale_, w_ - 1)];
    }
  }

  StereoParams params_;
  std::unique_ptr<pipeline::RowTeam> own_team_;
  pipeline::RowTeam* team_;
  CostModel model_;
  VoteRule vote_;
  kernels::pixel::BoundaryRule boundary_rule_;
  StereoTimings timings_;

  int scale_ = 1, w_ = 0, h_ = 0, max_d_ = 0;
  Image<std::uint8_t> small_left_, small_right_, gray_left_, gray_right_;
  ImageView<const std::uint8_t> ad_left_, ad_right_, census_gray_left_;
  Image<std::uint32_t> packed_left_, packed_right_;  // AD pixels, one word each
  Image<std::uint64_t> census_left_, census_right_;
  CrossArms arms_;
  Image<std::uint8_t> arm_scratch_, shortest_arm_;
  CostTables tables_;
  SupportRegions regions_;
  AggregationScratch agg_scratch_;
  DisparitySearch search_;
  WinnerTakesAll wta_;
  Image<std::int16_t> disp_;
  Image<std::uint8_t> changed_;
  VoteScratch vote_scratch_;
  Image<float> values_, raw_;
  Image<std::int16_t> jump_scratch_;
  std::vector<std::int32_t> lr_scratch_;
  SpeckleFilter speckles_;
  Image<std::uint8_t> full_grey_left_, full_grey_right_;
  BoundaryRefiner boundaries_;
  ImageView<const std::uint8_t> internal_left_, internal_right_;  // input channels, internal size
  CoarsePass half_, quarter_;                                     // the guide's passes
  std::array<Image<std::uint8_t>, 2> halves_, quarters_;          // left, right
  Image<float> previous_half_;
  GuideScratch guide_scratch_;
  BatchMask mask_, previous_mask_;
  // values_ is the previous frame's map (its size that frame's internal size), searched up to
  // previous_max_d_.
  bool has_previous_ = false;
  int previous_max_d_ = 0;
  // Disparity margins (internal pixels) of the temporal guide: the previous frame's values are
  // exact to a pixel but the surfaces move, the quarter pass's are four internal pixels apart.
  static constexpr int kPreviousMargin = 4;
  static constexpr int kQuarterMargin = 8;
};

}  // namespace

void check_stereo_input(const StereoParams& params, ImageView<const std::uint8_t> left,
                        ImageView<const std::uint8_t> right) {
  if (left.empty() || right.empty()) throw Error("stereo: empty input image");
  if (left.width != right.width || left.height != right.height || left.channels != right.channels)
    throw Error("stereo: left image is " + size_text(left) + " but right image is " +
                size_text(right) + "; a rectified pair has one size");
  if (left.channels != 1 && left.channels != 3)
    throw Error("stereo: images need 1 or 3 channels, not " + std::to_string(left.channels));
  check_stereo_size(params, left.width, left.height);
}

void check_stereo_size(const StereoParams& params, int width, int height) {
  const int scale = internal_scale(params, width);
  const int w = width / scale;
  const int h = height / scale;
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  // Above 640 px the stage matches at half size: the limits hold there, so the errors say so.
  if (w < params.census_width || h < params.census_height)
    throw Error("stereo: image " + size +
                (scale == 1 ? ""
                            : ", matched at half size (" + std::to_string(w) + "x" +
                                  std::to_string(h) + "),") +
                " is smaller than the " + std::to_string(params.census_width) + "x" +
                std::to_string(params.census_height) + " census window");
  const int max_d = params.max_disparity / scale;
  if (max_d < 1)
    throw Error("stereo: max disparity " + std::to_string(params.max_disparity) +
                " is no whole pixel at half size, where images over 640 px are matched: give at "
                "least 2");
  if (max_d >= w)
    throw Error("stereo: max disparity " + std::to_string(params.max_disparity) +
                (scale == 1 ? " must be smaller than the image width " + std::to_string(w)
                            : " (" + std::to_string(max_d) +
                                  " px at half size) must be smaller than the half-size width " +
                                  std::to_string(w) + " (image " + size + ")"));
}

std::unique_ptr<StereoMatcher> make_stereo_matcher(const StereoMatcherFactory& factory,
                                                   const StereoParams& params) {
  std::unique_ptr<StereoMatcher> stage =
      factory ? factory(params) : make_cpu_stereo_matcher(params);
  return params.exposure_balance || params.vertical_alignment || params.lens_falloff
             ? with_camera_alignment(std::move(stage))
             : std::move(stage);
}

int internal_scale(const StereoParams& params, int input_width) {
  if (params.internal_resolution == "full") return 1;
  if (params.internal_resolution == "half") return 2;
  return input_width > 640 ? 2 : 1;
}

std::unique_ptr<StereoMatcher> make_cpu_stereo_matcher(const StereoParams& params) {
  return std::make_unique<CpuStereoMatcher>(params);
}

}  // namespace dco::stereo
