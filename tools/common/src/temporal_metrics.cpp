#include "dco/tools/temporal_metrics.hpp"

#include <cmath>
#include <string>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr std::uint8_t kNoValue = 0xff;

std::uint8_t sides(float d, const FlickerMeter::Planes& planes) {
  if (!is_valid_disparity(d)) return kNoValue;
  std::uint8_t bits = 0;
  for (std::size_t k = 0; k < planes.size(); ++k)
    if (d > planes[k]) bits |= static_cast<std::uint8_t>(1u << k);
  return bits;
}

}  // namespace

void FlickerMeter::add(ImageView<const float> disparity) {
  if (disparity.empty() || disparity.channels != 1)
    throw Error("flicker: a disparity map must be a non-empty one-channel image");
  if (frames_ == 0) {
    if (!fixed_planes_) planes_ = occlusion_planes(disparity);
    previous_side_.resize(disparity.width, disparity.height);
  } else if (!previous_side_.view().same_size(disparity)) {
    throw Error("flicker: frame " + std::to_string(frames_) + " is " +
                std::to_string(disparity.width) + "x" + std::to_string(disparity.height) +
                ", the first frame " + std::to_string(previous_side_.width()) + "x" +
                std::to_string(previous_side_.height()));
  }
  for (int y = 0; y < disparity.height; ++y) {
    const float* d = disparity.row(y);
    std::uint8_t* prev = previous_side_.row(y);
    for (int x = 0; x < disparity.width; ++x) {
      const std::uint8_t now = sides(d[x], planes_);
      if (frames_ > 0 && (now != kNoValue || prev[x] != kNoValue)) {
        for (std::size_t k = 0; k < planes_.size(); ++k) {
          const bool both = now != kNoValue && prev[x] != kNoValue;
          const bool flipped = !both || (((now ^ prev[x]) >> k) & 1u);
          flips_ += flipped ? 1.0 : 0.0;
        }
        compared_ += static_cast<double>(planes_.size());
      }
      prev[x] = now;
    }
  }
  ++frames_;
}

double FlickerMeter::flip_rate() const {
  // Planes from a first frame without one valid disparity are NaN: no side is defined, so no
  // flip rate is either (rather than a rate that counts only the holes).
  for (const double plane : planes_)
    if (std::isnan(plane)) return kUndefined;
  return compared_ > 0 ? 100.0 * flips_ / compared_ : kUndefined;
}

}  // namespace dco::tools
