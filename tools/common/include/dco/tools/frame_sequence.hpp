#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "dco/core/calibration.hpp"
#include "dco/core/image.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::tools {

struct StereoInput {
  int index = 0;
  Image<std::uint8_t> left, right;  // rectified
  Image<float> gt_disparity;        // empty unless the source knows the truth
};

// Where dco-depth's sequence mode takes its frames from.
class FrameSequence {
 public:
  virtual ~FrameSequence() = default;
  // Fills `frame` with the next pair; false at the end.
  virtual bool next(StereoInput& frame) = 0;
  // The rectified geometry when known (for metric depth).
  virtual std::optional<RectifiedGeometry> geometry() const = 0;
  // A disparity range that covers the scene, when the source knows how near things come.
  virtual std::optional<int> max_disparity() const { return std::nullopt; }
};

// Numbered image files: printf-style patterns with one integer conversion ("I1_%06d.png"),
// from `first` for `count` frames (count < 0: until the first missing left image). With a
// calibration that needs it, frames are rectified first.
std::unique_ptr<FrameSequence> make_pattern_sequence(
    const std::string& left_pattern, const std::string& right_pattern, int first, int count,
    const std::optional<std::filesystem::path>& calib);

// How a synthetic right camera differs from the left, as a cheap pair's does
// (synthetic::SceneConfig::right_gain, right_offset, right_rows, right_roll_deg), and the lens
// fall-off both cameras share (lens_falloff).
struct SyntheticRightCamera {
  double gain = 1.0, offset = 0.0, rows = 0.0, roll_deg = 0.0;
  double lens_falloff = 0.0;
};

// A synthetic scene ("hand", "boxes", "static") with exact ground truth.
std::unique_ptr<FrameSequence> make_synthetic_sequence(const std::string& name, int width,
                                                       int height, int frames, bool color,
                                                       const SyntheticRightCamera& right = {});

// Expands a pattern for one index; throws dco::Error unless it holds exactly one %d-like field.
std::string expand_pattern(const std::string& pattern, int index);

}  // namespace dco::tools
