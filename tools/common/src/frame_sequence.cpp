#include "dco/tools/frame_sequence.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <regex>

#include "dco/core/calibration.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"

namespace dco::tools {
namespace {

class PatternSequence final : public FrameSequence {
 public:
  PatternSequence(std::string left, std::string right, int first, int count,
                  const std::optional<std::filesystem::path>& calib)
      : left_(std::move(left)),
        right_(std::move(right)),
        next_(first),
        end_(count < 0 ? -1 : std::int64_t{first} + count) {
    if (first < 0) throw Error("a pattern sequence starts at frame 0 or later");
    expand_pattern(left_, first);  // validates both patterns up front
    expand_pattern(right_, first);
    if (!calib) return;
    StereoCalibration c = load_calibration(*calib);
    rectifier_.emplace(c);
    // A rectified calibration without a size (Karlsruhe without roi) takes the first frame's,
    // and only then can its geometry be checked against a width.
    if (c.left.width == 0) unsized_ = std::move(c);
  }

  bool next(StereoInput& frame) override {
    // Numbers end at the largest int a %d field takes.
    if ((end_ >= 0 && next_ >= end_) || next_ > std::numeric_limits<int>::max()) return false;
    const int index = static_cast<int>(next_);
    const std::filesystem::path left = expand_pattern(left_, index);
    const std::filesystem::path right = expand_pattern(right_, index);
    // Open-ended: up to the first frame one of whose images is missing.
    if (end_ < 0 && (!std::filesystem::exists(left) || !std::filesystem::exists(right)))
      return false;
    Image<std::uint8_t> l = load_image(left);
    Image<std::uint8_t> r = load_image(right);
    if (unsized_) {
      unsized_->take_size_if_unknown(l.width(), l.height());
      rectifier_.emplace(*unsized_);
      unsized_.reset();
    }
    if (rectifier_) rectifier_->check_inputs(l.cview(), r.cview());
    if (rectifier_ && rectifier_->needs_remap()) {
      rectifier_->rectify(l.cview(), r.cview(), frame.left, frame.right);
    } else {
      frame.left = std::move(l);
      frame.right = std::move(r);
    }
    frame.index = index;
    ++next_;
    return true;
  }

  std::optional<RectifiedGeometry> geometry() const override {
    if (!rectifier_) return std::nullopt;
    return rectifier_->geometry();
  }

 private:
  std::string left_, right_;
  std::int64_t next_, end_;  // wide enough for first + count and one past the largest int
  std::optional<Rectifier> rectifier_;
  std::optional<StereoCalibration> unsized_;  // until the first frame gives it a size
};

class SyntheticSequence final : public FrameSequence {
 public:
  SyntheticSequence(synthetic::SceneConfig config, int frames)
      : renderer_(std::move(config)), frames_(frames) {}

  bool next(StereoInput& frame) override {
    if (next_ >= frames_) return false;
    renderer_.render(next_, sample_);
    frame.index = next_++;
    frame.left = sample_.left;
    frame.right = sample_.right;
    frame.gt_disparity = sample_.disparity;
    return true;
  }

  std::optional<RectifiedGeometry> geometry() const override {
    return renderer_.calibration().rectified;
  }

  std::optional<int> max_disparity() const override {
    return synthetic::covering_max_disparity(renderer_.config());
  }

 private:
  synthetic::SceneRenderer renderer_;
  synthetic::StereoSample sample_;
  int frames_;
  int next_ = 0;
};

}  // namespace

std::string expand_pattern(const std::string& pattern, int index) {
  static const std::regex kField("%0?([0-9]*)d");
  std::smatch field;
  const auto percents = std::count(pattern.begin(), pattern.end(), '%');
  if (percents != 1 || !std::regex_search(pattern, field, kField))
    throw Error("file pattern '" + pattern + "' needs exactly one integer field such as %06d");
  // An int has at most 11 characters; a wider field only pads (and a huge one takes seconds).
  constexpr int kMaxFieldWidth = 20;
  if (field[1].length() > 2 || (field[1].length() > 0 && std::stoi(field[1]) > kMaxFieldWidth))
    throw Error("file pattern '" + pattern + "': the field is wider than " +
                std::to_string(kMaxFieldWidth) + " characters");
  char buffer[4096];
  const int n = std::snprintf(buffer, sizeof buffer, pattern.c_str(), index);
  if (n < 0 || n >= static_cast<int>(sizeof buffer))
    throw Error("file pattern '" + pattern + "' expands to an overlong path");
  return buffer;
}

std::unique_ptr<FrameSequence> make_pattern_sequence(
    const std::string& left_pattern, const std::string& right_pattern, int first, int count,
    const std::optional<std::filesystem::path>& calib) {
  return std::make_unique<PatternSequence>(left_pattern, right_pattern, first, count, calib);
}

std::unique_ptr<FrameSequence> make_synthetic_sequence(const std::string& name, int width,
                                                       int height, int frames, bool color,
                                                       const SyntheticRightCamera& right) {
  synthetic::SceneConfig config = synthetic::preset(name, width, height);
  config.color = color;
  config.right_gain = right.gain;
  config.right_offset = right.offset;
  config.right_rows = right.rows;
  config.right_roll_deg = right.roll_deg;
  config.lens_falloff = right.lens_falloff;
  return std::make_unique<SyntheticSequence>(std::move(config), frames);
}

}  // namespace dco::tools
