#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>
#include <utility>

#include "dco/core/image.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"

namespace dco::stereo {
namespace {

constexpr int kFirstFrameRounds = 4;
// After a sequence's first frame the corrections are fitted again on every kRefitEvery-th frame:
// a camera's drift and exposure steps are followed within a few frames, at a quarter of the cost.
constexpr int kRefitEvery = 4;
// A fitted vertical offset replaces the one in force when they differ by this many rows, and so
// does a fitted roll, in rows at the side edges.
constexpr double kOffsetStep = 0.125;

class CameraAlignmentMatcher final : public StereoStageWrapper {
 public:
  explicit CameraAlignmentMatcher(std::unique_ptr<StereoMatcher> stage)
      : StereoStageWrapper(std::move(stage)) {}

  void compute(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
               Image<float>& disparity) override {
    // First, so that a bad pair is refused before anything reads it.
    check_stereo_input(params(), left, right);
    Stopwatch t;
    if (map_.count != left.channels) forget(left.channels);  // another kind of camera
    // Sized on the first frame, so that a correction found later allocates nothing.
    const StereoParams& p = params();
    if (p.vertical_alignment) aligned_.resize(right.width, right.height, right.channels);
    if (p.exposure_balance) balanced_.resize(right.width, right.height, right.channels);
    if (p.lens_falloff) {
      flat_left_.resize(left.width, left.height, left.channels);
      flat_right_.resize(right.width, right.height, right.channels);
      falloff_table_.build(falloff_, left.width, left.height, left.channels);
    }
    inner().compute(corrected_left(left), corrected(right), disparity);
    timings_ = inner().last_timings();
    // A sequence's first frame has no correction from frames before: its own matches give one,
    // and it is matched again through it while the correction still moves (a few times at most).
    // The first frame's last round is matched through the correction it reports: no fit after it
    // (its correction would differ from the one the disparity was matched with).
    const int rounds = first_ ? kFirstFrameRounds : 0;
    bool moved = (first_ || frames_ % kRefitEvery == 0) && refit(left, right, disparity);
    for (int round = 0; moved && round < rounds; ++round) {
      inner().reset();  // matched again as a new sequence
      inner().compute(corrected_left(left), corrected(right), disparity);
      timings_ = inner().last_timings();
      moved = round + 1 < rounds && refit(left, right, disparity);
    }
    first_ = false;
    ++frames_;
    t.lap_ms();
    timings_.balance_ms = t.total_ms() - timings_.total_ms;
    timings_.total_ms = t.total_ms();
  }

  void reset() override {
    inner().reset();
    forget(map_.count);
  }

  const StereoTimings& last_timings() const override { return timings_; }
  CameraCorrection last_correction() const override {
    return {map_, rows_.offset, rows_.roll, falloff_.k};
  }

 private:
  // The right image brought onto the left's rows, then through the exposure table, then the
  // lens fall-off's correction; each step only when it changes something.
  ImageView<const std::uint8_t> corrected(ImageView<const std::uint8_t> right) {
    if (!rows_.identity()) {
      align_rows(right, rows_, aligned_);
      right = aligned_.cview();
    }
    if (!table_.identity()) {
      table_.apply(right, balanced_);
      right = balanced_.cview();
    }
    if (falloff_table_.identity()) return right;
    falloff_table_.apply(right, flat_right_);
    return flat_right_.cview();
  }

  // The left image through the lens fall-off's correction, when there is one.
  ImageView<const std::uint8_t> corrected_left(ImageView<const std::uint8_t> left) {
    if (falloff_table_.identity()) return left;
    falloff_table_.apply(left, flat_left_);
    return flat_left_.cview();
  }

  // Fits the corrections to the matches; takes each that moves enough (the exposure map some
  // level by stereo.exposure_balance_levels, the offset or the roll at the side edges by
  // kOffsetStep rows) and then says so.
  bool refit(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
             const Image<float>& disparity) {
    const StereoParams& p = params();
    bool moved = false;
    // The right levels as the camera gave them, before the table and the fall-off's correction:
    // on the rows in force (which the vertical fit below has not changed yet, so aligned_ holds
    // this frame's).
    const ImageView<const std::uint8_t> levels = rows_.identity() ? right : aligned_.cview();
    if (p.exposure_balance) {
      ExposureMap fitted = map_;
      if (fit_exposure(left, levels, disparity.cview(), fitted)) {
        // A map fitted to matches made on rows found wrong since is no reference to keep:
        // the new fit is taken unless it lies within the threshold of no map, then no map.
        const ExposureMap none = no_exposure_map(map_.count);
        if (map_suspect_ && exposure_difference(fitted, none) < p.exposure_balance_levels)
          fitted = none;
        if (map_suspect_ ? exposure_difference(fitted, map_) > 0
                         : exposure_difference(fitted, map_) >= p.exposure_balance_levels) {
          map_ = fitted;
          table_.build(map_);
          moved = true;
        }
        map_suspect_ = false;
      }
    }
    if (p.lens_falloff) {
      // Fitted with its own gain and black level, so that the exposure map does not feed it.
      double k = falloff_.k;
      if (fit_lens_falloff(left, levels, disparity.cview(), k) &&
          falloff_difference(LensFalloff{k}, falloff_) >= p.exposure_balance_levels) {
        falloff_ = LensFalloff{k};
        falloff_table_.build(falloff_, left.width, left.height, left.channels);
        moved = true;
      }
    }
    if (p.vertical_alignment) {
      RowAlignment fitted = rows_;
      // A sequence's first frame searches the whole range: its matches improve with each round.
      if (fit_row_alignment(left, right, disparity.cview(), map_, first_, fitted)) {
        RowAlignment next = rows_;
        if (std::abs(fitted.offset - rows_.offset) >= kOffsetStep) next.offset = fitted.offset;
        const double half = 0.5 * (left.width - 1);
        if (std::abs(std::tan(fitted.roll) - std::tan(rows_.roll)) * half >= kOffsetStep)
          next.roll = fitted.roll;
        if (next != rows_) {
          rows_ = next;
          moved = true;
          // The map in force was fitted to matches made on the old rows.
          map_suspect_ = !table_.identity();
        }
      }
    }
    return moved;
  }

  // The next frame starts a sequence of its own: no correction, and a second match when it finds
  // one.
  void forget(int channels) {
    map_ = no_exposure_map(channels);
    table_.build(map_);
    rows_ = {};
    falloff_ = {};
    map_suspect_ = false;
    first_ = true;
    frames_ = 0;
  }

  ExposureMap map_;
  ExposureTable table_;
  RowAlignment rows_;    // of the right image's scene against the left's
  LensFalloff falloff_;  // of both lenses
  FalloffCorrection falloff_table_;
  bool map_suspect_ = false;  // map_ was fitted on rows found wrong since
  Image<std::uint8_t> aligned_, balanced_, flat_left_, flat_right_;
  StereoTimings timings_;
  bool first_ = true;
  long frames_ = 0;  // of the sequence
};

}  // namespace

bool CameraCorrection::identity() const {
  return same_levels() && row_offset == 0 && roll == 0 && falloff == 0;
}

bool CameraCorrection::same_levels() const {
  return levels == no_exposure_map(levels.count);
}

std::string describe(const CameraCorrection& correction) {
  if (correction.identity()) return "right camera as the left";
  const ExposureMap& m = correction.levels;
  static const char* const kNames[] = {" B", " G", " R"};
  std::string text = "right camera";
  char part[96];
  const bool same_levels = correction.same_levels();
  if (!same_levels) text += " levels";
  for (int c = 0; !same_levels && c < m.count; ++c) {
    const ChannelLevels& l = m.channels[static_cast<std::size_t>(c)];
    std::snprintf(part, sizeof part, "%s%s %.3f v %c %.1f", c > 0 ? "," : "",
                  m.count == 3 ? kNames[c] : "", l.gain, l.offset < 0 ? '-' : '+',
                  std::abs(l.offset));
    text += part;
  }
  const char* sep = same_levels ? "" : ",";
  if (correction.row_offset != 0) {
    std::snprintf(part, sizeof part, "%s rows %+.2f", sep, correction.row_offset);
    text += part;
    sep = ",";
  }
  if (correction.roll != 0) {
    std::snprintf(part, sizeof part, "%s roll %+.3f deg", sep,
                  correction.roll * 180.0 / std::numbers::pi);
    text += part;
    sep = ",";
  }
  if (correction.falloff == 0) return text;
  if (*sep == '\0') text += " as the left", sep = ",";  // the fall-off is both lenses'
  std::snprintf(part, sizeof part, "%s lens fall-off k %+.3f", sep, correction.falloff);
  return text + part;
}

std::unique_ptr<StereoMatcher> with_camera_alignment(std::unique_ptr<StereoMatcher> stage) {
  return std::make_unique<CameraAlignmentMatcher>(std::move(stage));
}

}  // namespace dco::stereo
