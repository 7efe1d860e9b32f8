#include "dco/tools/occlusion_error_map.hpp"

#include "plane_sides.hpp"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

void require_fits(ImageView<const float> map, ImageView<const float> gt, const char* what) {
  if (map.channels != 1 || !map.same_size(gt))
    throw Error(fmt::format("{} is {}x{}x{}, the ground truth {}x{}x1", what, map.width, map.height,
                            map.channels, gt.width, gt.height));
}

void paint(std::uint8_t* px, const std::uint8_t (&color)[3], bool full) {
  for (int c = 0; c < 3; ++c) px[c] = full ? color[c] : static_cast<std::uint8_t>(color[c] / 2);
}

}  // namespace

Image<std::uint8_t> occlusion_error_map(ImageView<const std::uint8_t> left,
                                        ImageView<const float> prediction,
                                        ImageView<const float> gt, double plane,
                                        ImageView<const float> matches) {
  if ((left.channels != 1 && left.channels != 3) || left.width != gt.width ||
      left.height != gt.height)
    throw Error(fmt::format("the left image is {}x{}x{}, the ground truth {}x{} (1 or 3 channels)",
                            left.width, left.height, left.channels, gt.width, gt.height));
  require_fits(prediction, gt, "the prediction");
  if (!matches.empty()) require_fits(matches, gt, "the sparse map");

  cv::Mat grey;  // the caller's pixels are only read
  if (left.channels == 3)
    cv::cvtColor(as_mat(left), grey, cv::COLOR_BGR2GRAY);
  else
    grey = as_mat(left);
  const cv::Mat truth = detail::plane_sides(gt, plane);
  const cv::Mat band = detail::occlusion_band(truth);
  using C = ErrorMapColors;
  Image<std::uint8_t> out(gt.width, gt.height, 3);
  for (int y = 0; y < gt.height; ++y) {
    const auto* l = grey.ptr<std::uint8_t>(y);
    const float* p = prediction.row(y);
    const float* m = matches.empty() ? nullptr : matches.row(y);
    const auto* t = truth.ptr<std::uint8_t>(y);
    const auto* b = band.ptr<std::uint8_t>(y);
    std::uint8_t* o = out.row(y);
    for (int x = 0; x < gt.width; ++x, o += 3) {
      o[0] = o[1] = o[2] = static_cast<std::uint8_t>(l[x] / 2);
      if (t[x] == detail::kNoValue) continue;
      const bool in_band = b[x] != 0;
      if (!is_valid_disparity(p[x])) {
        paint(o, C::kMissing, in_band);
        continue;
      }
      const bool front = p[x] > plane;
      if (front == (t[x] == detail::kFront)) {
        if (in_band) paint(o, C::kBandRight, true);
        continue;
      }
      const bool matched = m == nullptr || is_valid_disparity(m[x]);
      if (front)
        paint(o, matched ? C::kFrontMatched : C::kFrontFilled, in_band);
      else
        paint(o, matched ? C::kBehindMatched : C::kBehindFilled, in_band);
    }
  }
  return out;
}

}  // namespace dco::tools
