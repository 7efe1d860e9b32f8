#pragma once

#include <array>
#include <cstdint>

#include "dco/core/image.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {

// Temporal stability of an occlusion decision: for virtual fronto-parallel planes fixed by the
// first frame (its 20..80 % disparity quantiles, as in the accuracy metrics), the share of pixels
// whose side of each plane changes between consecutive frames. A renderer shows such a flip as
// a flicker of the virtual object's edge. A pixel without a value (+inf, NaN, <= 0) in one frame
// of a pair and with one in the other counts as a flip (a hole that comes and goes flickers too);
// one without a value in both is not compared (it has no side to change, and a ground truth's
// fixed gaps are no flicker).
class FlickerMeter {
 public:
  using Planes = std::array<double, kOcclusionPlaneQuantiles.size()>;

  // Planes from the first frame added.
  FlickerMeter() = default;
  // Fixed planes (e.g. from a ground-truth frame), so that two meters, say one on a prediction and
  // one on its ground truth, judge flips against the same planes.
  explicit FlickerMeter(const Planes& planes) : planes_(planes), fixed_planes_(true) {}

  // Adds the next frame's disparity map; all frames must have one size (throws dco::Error).
  void add(ImageView<const float> disparity);

  int frames() const { return frames_; }
  // Mean % of flipping pixels over consecutive pairs and planes; NaN before two frames.
  double flip_rate() const;
  const Planes& planes() const { return planes_; }

 private:
  Image<std::uint8_t> previous_side_;  // bit k set: in front of plane k; 0xff: no value
  Planes planes_{};
  bool fixed_planes_ = false;
  int frames_ = 0;
  double flips_ = 0;
  double compared_ = 0;
};

}  // namespace dco::tools
