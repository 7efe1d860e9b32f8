#include "dco/core/depth_conversion.hpp"

#include <cmath>
#include <limits>

#include "dco/core/error.hpp"

namespace dco {

void disparity_to_depth(ImageView<const float> disparity, const RectifiedGeometry& geometry,
                        ImageView<float> depth) {
  if (!depth.same_size(disparity) || disparity.channels != 1 || depth.channels != 1)
    throw Error("disparity_to_depth: depth image must match the one-channel disparity image");
  if (!(geometry.f > 0) || !(geometry.baseline_m > 0))
    throw Error("disparity_to_depth: the geometry has no focal length or baseline");
  const float fb = static_cast<float>(geometry.f * geometry.baseline_m);
  const float doffs = static_cast<float>(geometry.doffs());
  constexpr float kUnknown = std::numeric_limits<float>::infinity();
  for (int y = 0; y < disparity.height; ++y) {
    const float* d = disparity.row(y);
    float* z = depth.row(y);
    for (int x = 0; x < disparity.width; ++x) {
      const float denom = d[x] + doffs;
      z[x] = std::isfinite(d[x]) && denom > 0 ? fb / denom : kUnknown;
    }
  }
}

}  // namespace dco
