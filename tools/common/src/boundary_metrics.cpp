#include "dco/tools/boundary_metrics.hpp"

#include "plane_sides.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr auto kNone = detail::kNoValue;  // no GT, or no prediction

struct Boundaries {
  cv::Mat gt, predicted;  // 1 = boundary pixel
};

// Both maps' boundaries over the 4-neighbour pairs where both pixels have GT.
Boundaries find_boundaries(const cv::Mat& gt, const cv::Mat& pred) {
  Boundaries b{cv::Mat::zeros(gt.size(), CV_8U), cv::Mat::zeros(gt.size(), CV_8U)};
  const auto mark = [&](int x0, int y0, int x1, int y1) {
    const std::uint8_t g0 = gt.at<std::uint8_t>(y0, x0), g1 = gt.at<std::uint8_t>(y1, x1);
    if (g0 == kNone || g1 == kNone) return;
    if (g0 != g1) b.gt.at<std::uint8_t>(y0, x0) = b.gt.at<std::uint8_t>(y1, x1) = 1;
    const std::uint8_t p0 = pred.at<std::uint8_t>(y0, x0), p1 = pred.at<std::uint8_t>(y1, x1);
    if (p0 == p1) return;
    if (p0 != kNone) b.predicted.at<std::uint8_t>(y0, x0) = 1;
    if (p1 != kNone) b.predicted.at<std::uint8_t>(y1, x1) = 1;
  };
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      if (x + 1 < gt.cols) mark(x, y, x + 1, y);
      if (y + 1 < gt.rows) mark(x, y, x, y + 1);
    }
  return b;
}

// % of `boundary` pixels with a `reference` pixel within Chebyshev distance `tolerance`.
double matched_percent(const cv::Mat& boundary, const cv::Mat& reference, int tolerance) {
  const int count = cv::countNonZero(boundary);
  if (count == 0) return kUndefined;
  cv::Mat near;
  const int size = 2 * tolerance + 1;
  cv::dilate(reference, near, cv::getStructuringElement(cv::MORPH_RECT, {size, size}));
  cv::Mat matched;
  cv::bitwise_and(boundary, near, matched);
  return 100.0 * cv::countNonZero(matched) / count;
}

double mean_of_defined(const std::vector<double>& values) {
  double sum = 0;
  int n = 0;
  for (const double v : values)
    if (!std::isnan(v)) sum += v, ++n;
  return n > 0 ? sum / n : kUndefined;
}

}  // namespace

BoundaryAccuracy boundary_accuracy(ImageView<const float> prediction, ImageView<const float> gt,
                                   int tolerance) {
  const auto planes = occlusion_planes(gt);
  return boundary_accuracy(prediction, gt, planes, tolerance);
}

BoundaryAccuracy boundary_accuracy(ImageView<const float> prediction, ImageView<const float> gt,
                                   std::span<const double> planes, int tolerance) {
  if (prediction.channels != 1 || gt.channels != 1)
    throw Error("boundary accuracy: the prediction and the ground truth must be one-channel maps");
  if (!prediction.same_size(gt))
    throw Error(fmt::format("boundary accuracy: the prediction is {}x{} but the ground truth {}x{}",
                            prediction.width, prediction.height, gt.width, gt.height));
  if (tolerance < 0)
    throw Error(fmt::format("boundary accuracy: tolerance {} px is negative", tolerance));
  std::vector<BoundaryAccuracy> per_plane;
  for (const double plane : planes) {
    if (std::isnan(plane)) continue;
    const Boundaries b =
        find_boundaries(detail::plane_sides(gt, plane), detail::plane_sides(prediction, plane));
    // As for bandErr: a plane with no GT edge (e.g. one of a GT of a single value) has nothing to
    // find, and any tiny excess there would read as an edge.
    if (cv::countNonZero(b.gt) == 0) continue;
    per_plane.push_back({matched_percent(b.gt, b.predicted, tolerance),
                         matched_percent(b.predicted, b.gt, tolerance)});
  }
  return mean_boundary_accuracy(per_plane);
}

std::vector<double> gap_planes(ImageView<const float> gt, int count, double min_gap) {
  std::vector<float> values;
  for (int y = 0; y < gt.height; ++y)
    for (int x = 0; x < gt.width; ++x)
      if (is_valid_disparity(gt.row(y)[x])) values.push_back(gt.row(y)[x]);
  std::sort(values.begin(), values.end());
  values.erase(std::unique(values.begin(), values.end()), values.end());
  // The empty intervals are those between neighbouring distinct values.
  struct Gap {
    double width, centre;
  };
  std::vector<Gap> gaps;
  for (std::size_t i = 1; i < values.size(); ++i) {
    const double a = values[i - 1], b = values[i];
    if (b - a >= min_gap) gaps.push_back({b - a, 0.5 * (a + b)});
  }
  std::stable_sort(gaps.begin(), gaps.end(),
                   [](const Gap& g, const Gap& h) { return g.width > h.width; });
  std::vector<double> planes;
  for (std::size_t k = 0; k < gaps.size() && static_cast<int>(k) < count; ++k)
    planes.push_back(gaps[k].centre);
  std::sort(planes.begin(), planes.end());
  return planes;
}

BoundaryAccuracy mean_boundary_accuracy(std::span<const BoundaryAccuracy> maps) {
  std::vector<double> recall, precision;
  for (const BoundaryAccuracy& m : maps)
    recall.push_back(m.recall), precision.push_back(m.precision);
  return {mean_of_defined(recall), mean_of_defined(precision)};
}

}  // namespace dco::tools
