#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "dco/core/image.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/stereo_params.hpp"

namespace dco::stereo {

// Wall time of the last frame's sub-stages, named after the columns of the paper's Table 1.
struct StereoTimings {
  double prepare_ms = 0;   // downscale, grey conversion, census transform
  double arms_ms = 0;      // adaptive filter area construction
  double initial_ms = 0;   // cost, aggregation and winner-takes-all (initial parallax)
  double refine_ms = 0;    // left-right and uniqueness checks, histogram vote
  double sparse_ms = 0;    // subpixel fit and the map at input resolution
  double boundary_ms = 0;  // boundary refinement at input resolution (half-size matching only)
  // The right image moved and through the exposure map, the fits of both to the matches, and on
  // a sequence's first frame whose corrections moved, the matches before the last
  // (with_camera_alignment).
  double balance_ms = 0;
  double total_ms = 0;
  // Share of the (internal row, 16-disparity batch) pairs searched: 1 for a full search, less
  // when a coarser pass or the previous frame guided it (StereoParams::search_range).
  double searched_fraction = 1;
  double guide_ms = 0;  // that pass and the mask it gives, a part of initial_ms
};

// What the stage does to the right image before it matches (with_camera_alignment): the levels
// map, the vertical offset and the roll in force, fitted to the frames so far (the next frame is
// matched through them). A field engineer reads a camera's state from them: "the right camera
// reads 2.5 % brighter, its rows lie 0.3 below the left's, it is turned 0.05 degrees". All
// identity without the alignment.
struct CameraCorrection {
  ExposureMap levels;
  double row_offset = 0;  // rows the right image's scene lies below the left's (centre column)
  double roll = 0;        // radians it is turned about the centre (RowAlignment)
  double falloff = 0;     // k of both lenses' fall-off (LensFalloff), corrected in both images
  bool operator==(const CameraCorrection&) const = default;
  bool identity() const;
  bool same_levels() const;  // the levels map is the identity
};

// For a log line: "right camera levels 0.976 v + 0.1, rows +0.31, roll +0.050 deg" (per channel
// B, G, R in colour; each part only when it corrects something); "right camera as the left" for
// the identity.
std::string describe(const CameraCorrection& correction);

// The sparse stage: a rectified pair in, a disparity map out that carries values only where
// the checks trust them.
class StereoMatcher {
 public:
  virtual ~StereoMatcher() = default;

  // left/right: rectified, same size, 8-bit, both 1 or both 3 channels (BGR). Writes disparity in
  // pixels of the input image, +inf where no value survived the checks; `disparity` is resized
  // to the input size when needed (once, for a fixed geometry). Throws dco::Error on bad input.
  virtual void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                       Image<float>& disparity) = 0;

  // Forgets the previous frame (which stereo.search_range = temporal searches around): the next
  // frame starts a new, unrelated sequence.
  virtual void reset() {}
  virtual const StereoTimings& last_timings() const = 0;
  virtual CameraCorrection last_correction() const { return {}; }

  // What the last frame left at the internal resolution, for the stages that follow (valid until
  // the next compute; disparities in internal pixels): the internal downscale factor, the grey
  // left image, the winner-takes-all disparity of every pixel before any check (with its
  // subpixel fit), and the sparse map (+inf where no value survived).
  virtual int last_scale() const = 0;
  virtual ImageView<const std::uint8_t> internal_left_gray() const = 0;
  virtual ImageView<const float> internal_raw_disparity() const = 0;
  virtual ImageView<const float> internal_sparse_disparity() const = 0;
  virtual const StereoParams& params() const = 0;
};

// A stage around another one that changes what goes in or when (the camera alignment below):
// what a frame leaves at the internal resolution, the timings and the params are the inner
// stage's unless the wrapper says otherwise.
class StereoStageWrapper : public StereoMatcher {
 public:
  explicit StereoStageWrapper(std::unique_ptr<StereoMatcher> stage) : stage_(std::move(stage)) {}
  void reset() override { stage_->reset(); }
  const StereoTimings& last_timings() const override { return stage_->last_timings(); }
  CameraCorrection last_correction() const override { return stage_->last_correction(); }
  int last_scale() const override { return stage_->last_scale(); }
  ImageView<const std::uint8_t> internal_left_gray() const override {
    return stage_->internal_left_gray();
  }
  ImageView<const float> internal_raw_disparity() const override {
    return stage_->internal_raw_disparity();
  }
  ImageView<const float> internal_sparse_disparity() const override {
    return stage_->internal_sparse_disparity();
  }
  const StereoParams& params() const override { return stage_->params(); }

 protected:
  StereoMatcher& inner() { return *stage_; }

 private:
  std::unique_ptr<StereoMatcher> stage_;
};

// Internal downscale factor (1 or 2) for an input width under the params.
int internal_scale(const StereoParams& params, int input_width);

// Throws dco::Error when frames of this size cannot go through the stage under these params (too
// small for the census window, max disparity not below the width, both at the internal size).
void check_stereo_size(const StereoParams& params, int width, int height);
// The same for a pair, which must also be non-empty, of one size and of 1 or 3 channels.
void check_stereo_input(const StereoParams& params, ImageView<const std::uint8_t> left,
                        ImageView<const std::uint8_t> right);

// Throws dco::Error when the params are invalid.
std::unique_ptr<StereoMatcher> make_cpu_stereo_matcher(const StereoParams& params);

// The stage with the right image brought to the left's before it matches: moved by the vertical
// offset and turned back by the roll a drifted calibration leaves (vertical_alignment.hpp,
// stereo.vertical_alignment), its
// levels mapped onto the left's (exposure_balance.hpp, stereo.exposure_balance). Each frame is
// matched through the corrections fitted to the frames before it; the matches of every fourth
// frame give the next fits; a sequence's first frame is matched again through the corrections its
// own matches give, while they still move (four times at most). A fit replaces a correction only
// when it moves it enough (some level by stereo.exposure_balance_levels, the offset or the roll
// at the side edges by 1/8 row), so
// a pair that agrees keeps its bytes and the corrections do not follow the fits' noise; an
// exposure map in force when the rows move was fitted to misaligned matches and is judged
// afresh by the next fit (kept only if that fit lies the threshold or more from no map).
std::unique_ptr<StereoMatcher> with_camera_alignment(std::unique_ptr<StereoMatcher> stage);

// Makes the stage of a backend (CPU, CUDA), with the camera alignment when its params ask for
// it; an empty factory means the CPU one.
using StereoMatcherFactory = std::function<std::unique_ptr<StereoMatcher>(const StereoParams&)>;
std::unique_ptr<StereoMatcher> make_stereo_matcher(const StereoMatcherFactory& factory,
                                                   const StereoParams& params);

}  // namespace dco::stereo
