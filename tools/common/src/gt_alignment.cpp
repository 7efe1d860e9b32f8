#include "dco/tools/gt_alignment.hpp"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

// Grey step between a pixel's row neighbours below which its photometric error says nothing.
constexpr int kMinStep = 16;

struct Probe {
  float left;  // grey level of the left pixel
  float at;    // x − gt in the right image at δ = 0
  int row;
};

}  // namespace

GtAlignment photometric_gt_alignment(ImageView<const std::uint8_t> left,
                                     ImageView<const std::uint8_t> right, ImageView<const float> gt,
                                     double range_px, double step_px) {
  if (left.channels != 1 || right.channels != 1 || gt.channels != 1)
    throw Error("GT alignment: the images and the GT must have one channel");
  if (!left.same_size(gt.width, gt.height) || !right.same_size(gt.width, gt.height))
    throw Error(fmt::format("GT alignment: the images are {}x{} and {}x{}, the GT {}x{}",
                            left.width, left.height, right.width, right.height, gt.width,
                            gt.height));
  if (!(range_px >= 0) || !(step_px > 0) || range_px / step_px > 1000)
    throw Error(
        fmt::format("GT alignment: bad offset range {} px or step {} px", range_px, step_px));
  std::vector<Probe> probes;
  for (int y = 0; y < gt.height; ++y) {
    const std::uint8_t* l = left.row(y);
    const float* d = gt.row(y);
    for (int x = 1; x + 1 < gt.width; ++x) {
      if (!is_valid_disparity(d[x]) || std::abs(int{l[x + 1]} - int{l[x - 1]}) < kMinStep) continue;
      const double at = x - static_cast<double>(d[x]);
      if (at - range_px < 0 || at + range_px + 1 > gt.width - 1) continue;
      probes.push_back({static_cast<float>(l[x]), static_cast<float>(at), y});
    }
  }
  if (probes.empty())
    throw Error("GT alignment: no GT pixel with texture whose match lies inside the right image");

  const int steps = static_cast<int>(std::floor(range_px / step_px + 1e-9));
  GtAlignment best;
  best.pixels = static_cast<std::int64_t>(probes.size());
  double best_error = std::numeric_limits<double>::infinity();
  for (int i = -steps; i <= steps; ++i) {
    const double delta = i * step_px;
    double sum = 0;
    for (const Probe& p : probes) {
      const double xr = p.at - delta;
      const int x0 = static_cast<int>(std::floor(xr));
      const double a = xr - x0;
      const std::uint8_t* r = right.row(p.row);
      sum += std::abs((1 - a) * r[x0] + a * r[x0 + 1] - p.left);
    }
    const double error = sum / static_cast<double>(probes.size());
    if (i == 0) best.error_at_zero = error;
    // Ties keep the offset nearest zero: i runs up from -steps, so prefer |i| smaller.
    if (error < best_error || (error == best_error && std::abs(delta) < std::abs(best.offset_px))) {
      best_error = error;
      best.offset_px = delta;
    }
  }
  best.error_at_offset = best_error;
  return best;
}

Image<float> shifted_ground_truth(ImageView<const float> gt, double offset_px) {
  Image<float> out(gt.width, gt.height);
  const auto offset = static_cast<float>(offset_px);
  for (int y = 0; y < gt.height; ++y) {
    const float* in = gt.row(y);
    float* o = out.row(y);
    for (int x = 0; x < gt.width; ++x) o[x] = is_valid_disparity(in[x]) ? in[x] + offset : in[x];
  }
  return out;
}

}  // namespace dco::tools
