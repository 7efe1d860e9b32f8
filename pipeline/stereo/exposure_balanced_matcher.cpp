#include <memory>
#include <utility>

#include "dco/core/image.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco::stereo {
namespace {

constexpr int kFirstFrameRounds = 4;

class ExposureBalancedMatcher final : public StereoMatcher {
 public:
  explicit ExposureBalancedMatcher(std::unique_ptr<StereoMatcher> stage)
      : stage_(std::move(stage)) {}

  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    // First, so that a bad pair is refused before anything reads it.
    check_stereo_input(stage_->params(), left, right);
    Stopwatch t;
    if (map_.count != left.channels) forget(left.channels);  // another kind of camera
    // Sized on the first frame, so that a map found later allocates nothing.
    right_.resize(right.width, right.height, right.channels);
    stage_->compute(left, balanced(right), disparity);
    timings_ = stage_->last_timings();
    // A sequence's first frame has no map from frames before: its own matches give one, and
    // it is matched again through it while the map still moves (a few times at most).
    const int rounds = first_ ? kFirstFrameRounds : 0;
    for (int round = 0; refit(left, right, disparity) && round < rounds; ++round) {
      stage_->reset();  // matched again as a new sequence
      stage_->compute(left, balanced(right), disparity);
      timings_ = stage_->last_timings();
    }
    first_ = false;
    t.lap_ms();
    timings_.balance_ms = t.total_ms() - timings_.total_ms;
    timings_.total_ms = t.total_ms();
  }

  void reset() override {
    stage_->reset();
    forget(map_.count);
  }

  const StereoTimings& last_timings() const override { return timings_; }
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

 private:
  // Fits the map to the matches; takes it when it moves some level by
  // stereo.exposure_balance_levels or more, and then says so.
  bool refit(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
             const Image<float>& disparity) {
    ExposureMap fitted = map_;
    if (!fit_exposure(left, right, disparity.cview(), fitted)) return false;
    if (exposure_difference(fitted, map_) < stage_->params().exposure_balance_levels) return false;
    map_ = fitted;
    table_.build(map_);
    return true;
  }

  ImageView<const std::uint8_t> balanced(ImageView<const std::uint8_t> right) {
    if (table_.identity()) return right;
    table_.apply(right, right_);
    return right_.cview();
  }

  // The next frame starts a sequence of its own: no map, and a second match when it finds one.
  void forget(int channels) {
    map_ = ExposureMap{};
    map_.count = channels;
    table_.build(map_);
    first_ = true;
  }

  std::unique_ptr<StereoMatcher> stage_;
  ExposureMap map_;
  ExposureTable table_;
  Image<std::uint8_t> right_;
  StereoTimings timings_;
  bool first_ = true;
};

}  // namespace

std::unique_ptr<StereoMatcher> with_exposure_balance(std::unique_ptr<StereoMatcher> stage) {
  return std::make_unique<ExposureBalancedMatcher>(std::move(stage));
}

}  // namespace dco::stereo
