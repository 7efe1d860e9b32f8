#include "dco/tools/gt_noise.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "dco/core/error.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {

Image<float> noisy_ground_truth(ImageView<const float> gt, double sigma_px, std::uint64_t seed) {
  if (!(sigma_px >= 0) || !std::isfinite(sigma_px))
    throw Error(fmt::format("noise sigma must be a finite number >= 0, not {}", sigma_px));
  cv::RNG rng(seed);
  Image<float> out(gt.width, gt.height);
  for (int y = 0; y < gt.height; ++y) {
    const float* in = gt.row(y);
    float* o = out.row(y);
    for (int x = 0; x < gt.width; ++x) {
      if (!is_valid_disparity(in[x])) {
        o[x] = in[x];
        continue;
      }
      const float noisy = in[x] + static_cast<float>(rng.gaussian(sigma_px));
      o[x] = noisy > 0 ? noisy : std::numeric_limits<float>::min();
    }
  }
  return out;
}

}  // namespace dco::tools
