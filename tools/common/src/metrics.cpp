#include "dco/tools/metrics.hpp"

#include "plane_sides.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

double percent(std::int64_t part, std::int64_t whole) {
  return whole > 0 ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : kUndefined;
}

// Running sums behind one ErrorStats.
struct ErrorAccumulator {
  std::int64_t pixels = 0, bad1 = 0, bad2 = 0, bad4 = 0;
  double sum_abs = 0;

  // `abs_err` < 0 marks a missing prediction: bad at every threshold.
  void add(double abs_err, double gt) {
    ++pixels;
    const bool missing = abs_err < 0;
    bad1 += missing || abs_err > 1;
    bad2 += missing || abs_err > 2;
    bad4 += missing || abs_err > 4;
    sum_abs += missing ? gt : abs_err;
  }

  ErrorStats stats() const {
    ErrorStats s;
    s.pixels = pixels;
    s.bad1 = percent(bad1, pixels);
    s.bad2 = percent(bad2, pixels);
    s.bad4 = percent(bad4, pixels);
    s.avgerr = pixels > 0 ? sum_abs / static_cast<double>(pixels) : kUndefined;
    return s;
  }
};

double mean_of_defined(std::span<const double> values) {
  double sum = 0;
  int n = 0;
  for (const double v : values) {
    if (std::isnan(v)) continue;
    sum += v;
    ++n;
  }
  return n > 0 ? sum / n : kUndefined;
}

using detail::band_around;
using detail::kBehind;
using detail::kFront;
using detail::occlusion_band;
constexpr auto kNoGt = detail::kNoValue;

// Around the GT depth edges: pairs with GT whose disparities differ by more than kDepthEdgeJump.
cv::Mat depth_edge_zone(ImageView<const float> gt) {
  return band_around(gt.width, gt.height, [&gt](int x0, int y0, int x1, int y1) {
    const float a = gt.row(y0)[x0], b = gt.row(y1)[x1];
    return is_valid_disparity(a) && is_valid_disparity(b) && std::abs(a - b) > kDepthEdgeJump;
  });
}

struct PlaneErrors {
  double occ, occ_pred, band, band_pred, band_front, band_behind, band_edge, band_surface,
      band_matched, band_filled;
};

// `matches` may be empty (no sparse map): every band error then counts as filled, and the caller
// leaves both shares undefined.
PlaneErrors plane_errors(ImageView<const float> prediction, ImageView<const float> gt,
                         ImageView<const float> matches, const cv::Mat& edge_zone, double plane) {
  const cv::Mat sides = detail::plane_sides(gt, plane);
  const cv::Mat band = occlusion_band(sides);
  std::int64_t n = 0, wrong = 0, n_pred = 0, wrong_pred = 0;
  std::int64_t n_band = 0, wrong_band = 0, n_band_pred = 0, wrong_band_pred = 0;
  std::int64_t band_front = 0, band_behind = 0, band_edge = 0, band_matched = 0;
  for (int y = 0; y < gt.height; ++y) {
    const float* p = prediction.row(y);
    const auto* s = sides.ptr<std::uint8_t>(y);
    const auto* in_band = band.ptr<std::uint8_t>(y);
    const auto* near_edge = edge_zone.ptr<std::uint8_t>(y);
    const float* match = matches.empty() ? nullptr : matches.row(y);
    for (int x = 0; x < gt.width; ++x) {
      if (s[x] == kNoGt) continue;
      const bool predicted = is_valid_disparity(p[x]);
      const bool is_wrong = !predicted || (p[x] > plane) != (s[x] == kFront);
      n += 1, wrong += is_wrong;
      n_pred += predicted, wrong_pred += predicted && is_wrong;
      if (in_band[x]) {
        n_band += 1, wrong_band += is_wrong;
        n_band_pred += predicted, wrong_band_pred += predicted && is_wrong;
        band_front += predicted && is_wrong && s[x] != kFront;
        band_behind += predicted && is_wrong && s[x] == kFront;
        band_edge += is_wrong && near_edge[x];
        band_matched += is_wrong && match != nullptr && is_valid_disparity(match[x]);
      }
    }
  }
  return {percent(wrong, n),
          percent(wrong_pred, n_pred),
          percent(wrong_band, n_band),
          percent(wrong_band_pred, n_band_pred),
          percent(band_front, n_band),
          percent(band_behind, n_band),
          percent(band_edge, n_band),
          percent(wrong_band - band_edge, n_band),
          percent(band_matched, n_band),
          percent(wrong_band - band_matched, n_band)};
}

void add_occlusion_metrics(ImageView<const float> prediction, ImageView<const float> gt,
                           ImageView<const float> matches, SceneMetrics& m) {
  m.planes = occlusion_planes(gt);
  constexpr std::size_t kPlanes = kOcclusionPlaneQuantiles.size();
  std::array<double, kPlanes> occ{}, occ_pred{}, band{}, band_pred{}, front{}, behind{}, edge{},
      surface{}, matched{}, filled{};
  const cv::Mat edge_zone = depth_edge_zone(gt);
  for (std::size_t i = 0; i < kPlanes; ++i) {
    if (std::isnan(m.planes[i])) {
      occ[i] = occ_pred[i] = band[i] = band_pred[i] = front[i] = behind[i] = edge[i] = surface[i] =
          matched[i] = filled[i] = kUndefined;
      continue;
    }
    const PlaneErrors e = plane_errors(prediction, gt, matches, edge_zone, m.planes[i]);
    occ[i] = e.occ, occ_pred[i] = e.occ_pred, band[i] = e.band, band_pred[i] = e.band_pred;
    front[i] = e.band_front, behind[i] = e.band_behind;
    edge[i] = e.band_edge, surface[i] = e.band_surface, matched[i] = e.band_matched;
    filled[i] = e.band_filled;
  }
  m.occ_err = mean_of_defined(occ);
  m.occ_err_pred = mean_of_defined(occ_pred);
  m.band_err = mean_of_defined(band);
  m.band_err_pred = mean_of_defined(band_pred);
  m.band_front = mean_of_defined(front);
  m.band_behind = mean_of_defined(behind);
  m.band_edge = mean_of_defined(edge);
  m.band_surface = mean_of_defined(surface);
  if (!matches.empty()) {
    m.band_matched = mean_of_defined(matched);
    m.band_filled = mean_of_defined(filled);
  }
}

// Scenes without the numbers (e.g. no nocc mask) hold NaN and drop out of the mean by themselves.
ErrorStats mean_stats(std::span<const SceneMetrics> scenes, ErrorStats SceneMetrics::*member) {
  std::vector<double> bad1, bad2, bad4, avgerr;
  ErrorStats mean;
  for (const SceneMetrics& s : scenes) {
    const ErrorStats& e = s.*member;
    mean.pixels += e.pixels;
    bad1.push_back(e.bad1), bad2.push_back(e.bad2), bad4.push_back(e.bad4);
    avgerr.push_back(e.avgerr);
  }
  mean.bad1 = mean_of_defined(bad1);
  mean.bad2 = mean_of_defined(bad2);
  mean.bad4 = mean_of_defined(bad4);
  mean.avgerr = mean_of_defined(avgerr);
  return mean;
}

double mean_field(std::span<const SceneMetrics> scenes, double SceneMetrics::*member) {
  std::vector<double> values;
  for (const SceneMetrics& s : scenes) values.push_back(s.*member);
  return mean_of_defined(values);
}

}  // namespace

std::array<double, kOcclusionPlaneQuantiles.size()> occlusion_planes(ImageView<const float> gt) {
  std::vector<float> values;
  for (int y = 0; y < gt.height; ++y)
    for (int x = 0; x < gt.width; ++x)
      if (is_valid_disparity(gt.at(x, y))) values.push_back(gt.at(x, y));

  std::array<double, kOcclusionPlaneQuantiles.size()> planes{};
  if (values.empty()) {
    planes.fill(kUndefined);
    return planes;
  }
  const auto n = static_cast<std::ptrdiff_t>(values.size());
  for (std::size_t i = 0; i < planes.size(); ++i) {
    // Nearest rank: the smallest value with at least q * n values at or below it. The epsilon keeps
    // q * n = 65.000000000000014 (0.65 is not exact in binary) from rounding up a whole rank.
    const double at_least = kOcclusionPlaneQuantiles[i] * static_cast<double>(n);
    const auto rank = static_cast<std::ptrdiff_t>(std::ceil(at_least - 1e-9)) - 1;
    const std::ptrdiff_t k = std::clamp<std::ptrdiff_t>(rank, 0, n - 1);
    std::nth_element(values.begin(), values.begin() + k, values.end());
    const float at_rank = values[k];
    float next = at_rank;  // next larger distinct value, if any (all later ones are >= at_rank)
    for (std::ptrdiff_t j = k + 1; j < n; ++j)
      if (values[j] > at_rank && (next == at_rank || values[j] < next)) next = values[j];
    if (next == at_rank)  // the largest value: the plane goes below it (all earlier are <=)
      for (std::ptrdiff_t j = 0; j < k; ++j)
        if (values[j] < at_rank && (next == at_rank || values[j] > next)) next = values[j];
    // One value only: no depth edge to put a plane in, and a plane on the surface itself would
    // count any error, however small, as the wrong side.
    planes[i] = next == at_rank ? kUndefined
                                : 0.5 * (static_cast<double>(at_rank) + static_cast<double>(next));
  }
  return planes;
}

SceneMetrics evaluate_disparity(std::string scene, ImageView<const float> prediction,
                                const GroundTruth& gt, ImageView<const float> matches) {
  const ImageView<const float> truth = gt.disparity.view();
  if (prediction.channels != 1)
    throw Error(fmt::format("scene '{}': the prediction has {} channels, expected 1", scene,
                            prediction.channels));
  if (!prediction.same_size(truth))
    throw Error(fmt::format("scene '{}': the prediction is {}x{} but the ground truth is {}x{}",
                            scene, prediction.width, prediction.height, truth.width, truth.height));
  const bool has_matches = !matches.empty();
  if (has_matches && (matches.channels != 1 || !matches.same_size(truth)))
    throw Error(fmt::format("scene '{}': the sparse map is {}x{}x{}, the ground truth {}x{}x1",
                            scene, matches.width, matches.height, matches.channels, truth.width,
                            truth.height));
  const bool has_nocc = !gt.nocc.empty();
  if (has_nocc && !gt.nocc.view().same_size(truth))
    throw Error(
        fmt::format("scene '{}': the nocc mask and the ground truth differ in size", scene));

  SceneMetrics m;
  m.scene = std::move(scene);
  m.width = truth.width;
  m.height = truth.height;
  m.has_nocc = has_nocc;
  ErrorAccumulator all, pred, nocc, nocc_pred, matched, filled;
  for (int y = 0; y < truth.height; ++y) {
    const float* g = truth.row(y);
    const float* p = prediction.row(y);
    const std::uint8_t* mask = has_nocc ? gt.nocc.row(y) : nullptr;
    const float* match = has_matches ? matches.row(y) : nullptr;
    for (int x = 0; x < truth.width; ++x) {
      if (!is_valid_disparity(g[x])) continue;
      const bool predicted = is_valid_disparity(p[x]);
      const double abs_err = predicted ? std::abs(static_cast<double>(p[x]) - g[x]) : -1.0;
      const bool non_occluded = mask != nullptr && mask[x] == 255;
      all.add(abs_err, g[x]);
      if (predicted) pred.add(abs_err, g[x]);
      if (non_occluded) nocc.add(abs_err, g[x]);
      if (non_occluded && predicted) nocc_pred.add(abs_err, g[x]);
      if (match != nullptr) (is_valid_disparity(match[x]) ? matched : filled).add(abs_err, g[x]);
    }
  }
  m.gt_pixels = all.pixels;
  m.predicted_pixels = pred.pixels;
  m.density = percent(pred.pixels, all.pixels);
  m.all = all.stats();
  m.pred = pred.stats();
  if (has_nocc) {
    m.nocc = nocc.stats();
    m.nocc_pred = nocc_pred.stats();
  }
  m.has_matches = has_matches;
  if (has_matches) {
    m.filled = percent(filled.pixels, all.pixels);
    m.matched = matched.stats();
    m.filled_err = filled.stats();
  }
  add_occlusion_metrics(prediction, truth, matches, m);
  return m;
}

SceneMetrics mean_metrics(std::span<const SceneMetrics> scenes) {
  SceneMetrics mean;
  mean.scene = "mean";
  for (const SceneMetrics& s : scenes) {
    mean.gt_pixels += s.gt_pixels;
    mean.predicted_pixels += s.predicted_pixels;
    mean.has_nocc = mean.has_nocc || s.has_nocc;
    mean.has_matches = mean.has_matches || s.has_matches;
  }
  mean.density = mean_field(scenes, &SceneMetrics::density);
  mean.all = mean_stats(scenes, &SceneMetrics::all);
  mean.pred = mean_stats(scenes, &SceneMetrics::pred);
  if (mean.has_nocc) {
    mean.nocc = mean_stats(scenes, &SceneMetrics::nocc);
    mean.nocc_pred = mean_stats(scenes, &SceneMetrics::nocc_pred);
  }
  if (mean.has_matches) {
    mean.filled = mean_field(scenes, &SceneMetrics::filled);
    mean.matched = mean_stats(scenes, &SceneMetrics::matched);
    mean.filled_err = mean_stats(scenes, &SceneMetrics::filled_err);
    mean.band_matched = mean_field(scenes, &SceneMetrics::band_matched);
    mean.band_filled = mean_field(scenes, &SceneMetrics::band_filled);
  }
  mean.planes.fill(kUndefined);
  mean.occ_err = mean_field(scenes, &SceneMetrics::occ_err);
  mean.occ_err_pred = mean_field(scenes, &SceneMetrics::occ_err_pred);
  mean.band_err = mean_field(scenes, &SceneMetrics::band_err);
  mean.band_err_pred = mean_field(scenes, &SceneMetrics::band_err_pred);
  mean.band_front = mean_field(scenes, &SceneMetrics::band_front);
  mean.band_behind = mean_field(scenes, &SceneMetrics::band_behind);
  mean.band_edge = mean_field(scenes, &SceneMetrics::band_edge);
  mean.band_surface = mean_field(scenes, &SceneMetrics::band_surface);
  // A time mean over some of the scenes would compare unequal workloads: all or nothing.
  const bool all_timed = std::none_of(scenes.begin(), scenes.end(),
                                      [](const SceneMetrics& s) { return std::isnan(s.time_ms); });
  mean.time_ms = all_timed ? mean_field(scenes, &SceneMetrics::time_ms) : kUndefined;
  return mean;
}

std::vector<KeyComparison> compare_key_metrics(const SceneMetrics& a, const SceneMetrics& b) {
  const auto row = [](std::string metric, std::string label, double va, double vb) {
    KeyComparison c{std::move(metric), std::move(label), va, vb, va - vb, kUndefined};
    if (vb != 0) c.ratio = va / vb;  // NaN in, NaN out
    return c;
  };
  return {
      row("density", "density %", a.density, b.density),
      row("bad2_pred", "bad-2 pred %", a.pred.bad2, b.pred.bad2),
      row("bad2_all", "bad-2 all %", a.all.bad2, b.all.bad2),
      row("occ_err", "occErr %", a.occ_err, b.occ_err),
      row("band_err", "bandErr %", a.band_err, b.band_err),
      row("time_ms", "time ms", a.time_ms, b.time_ms),
  };
}

}  // namespace dco::tools
