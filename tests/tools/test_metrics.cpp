#include "dco/tools/metrics.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"

namespace dco::tools {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A 20x10 scene whose numbers are all countable by hand:
//   GT: a foreground strip (disparity 20) in columns 0..2, background (10) in columns 3..19, so
//       170 of the 200 GT pixels are 10 and every quantile plane sits at (10 + 20) / 2 = 15.
//   nocc mask: 255 except column 3 (128).
//   prediction: the GT shifted right by one column (column 3 becomes 20: 10 px off by 10 and on the
//       wrong side of the planes), plus row 0 columns 10..14 off by 1.5, row 1 columns 10..14 off
//       by 3 (both still behind the planes), and no prediction in column 19 (inf, NaN, 0, < 0).
//   GT occlusion boundary: columns 2 and 3; the band within 3 px: columns 0..6 = 70 pixels.
constexpr int kW = 20, kH = 10;

GroundTruth step_edge_gt() {
  GroundTruth gt;
  gt.disparity.resize(kW, kH);
  gt.nocc.resize(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      gt.disparity.at(x, y) = x < 3 ? 20.0f : 10.0f;
      gt.nocc.at(x, y) = x == 3 ? 128 : 255;
    }
  return gt;
}

Image<float> shifted_prediction(const GroundTruth& gt) {
  Image<float> pred(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) pred.at(x, y) = gt.disparity.at(x == 0 ? 0 : x - 1, y);
  for (int x = 10; x < 15; ++x) {
    pred.at(x, 0) = 11.5f;
    pred.at(x, 1) = 13.0f;
  }
  const float missing[kH] = {kInf, kInf, kInf, kNaN, kNaN, kNaN, 0.0f, 0.0f, -5.0f, -kInf};
  for (int y = 0; y < kH; ++y) pred.at(kW - 1, y) = missing[y];
  return pred;
}

TEST(Metrics, StepEdgeDensityAndBadN) {
  const GroundTruth gt = step_edge_gt();
  const SceneMetrics m = evaluate_disparity("step", shifted_prediction(gt).view(), gt);
  EXPECT_EQ(m.scene, "step");
  EXPECT_EQ(m.width, kW);
  EXPECT_EQ(m.height, kH);
  EXPECT_EQ(m.gt_pixels, 200);
  EXPECT_EQ(m.predicted_pixels, 190);
  EXPECT_DOUBLE_EQ(m.density, 95.0);

  // All GT pixels: 10 (column 3) + 10 (missing) bad at every N, + 5 at 1.5 px, + 5 at 3 px.
  EXPECT_EQ(m.all.pixels, 200);
  EXPECT_DOUBLE_EQ(m.all.bad1, 100.0 * 30 / 200);
  EXPECT_DOUBLE_EQ(m.all.bad2, 100.0 * 25 / 200);
  EXPECT_DOUBLE_EQ(m.all.bad4, 100.0 * 20 / 200);
  // Missing predictions count as |err| = GT = 10.
  EXPECT_DOUBLE_EQ(m.all.avgerr, (10 * 10 + 5 * 1.5 + 5 * 3 + 10 * 10) / 200.0);

  EXPECT_EQ(m.pred.pixels, 190);
  EXPECT_DOUBLE_EQ(m.pred.bad1, 100.0 * 20 / 190);
  EXPECT_DOUBLE_EQ(m.pred.bad2, 100.0 * 15 / 190);
  EXPECT_DOUBLE_EQ(m.pred.bad4, 100.0 * 10 / 190);
  EXPECT_DOUBLE_EQ(m.pred.avgerr, (10 * 10 + 5 * 1.5 + 5 * 3) / 190.0);
}

TEST(Metrics, StepEdgeNonOccludedSkipsTheMaskedColumn) {
  const GroundTruth gt = step_edge_gt();
  const SceneMetrics m = evaluate_disparity("step", shifted_prediction(gt).view(), gt);
  ASSERT_TRUE(m.has_nocc);
  // Column 3 (the shifted one) is masked out; column 19 (missing) is still in.
  EXPECT_EQ(m.nocc.pixels, 190);
  EXPECT_DOUBLE_EQ(m.nocc.bad1, 100.0 * 20 / 190);
  EXPECT_DOUBLE_EQ(m.nocc.bad2, 100.0 * 15 / 190);
  EXPECT_DOUBLE_EQ(m.nocc.bad4, 100.0 * 10 / 190);
  EXPECT_DOUBLE_EQ(m.nocc.avgerr, (5 * 1.5 + 5 * 3 + 10 * 10) / 190.0);
  EXPECT_EQ(m.nocc_pred.pixels, 180);
  EXPECT_DOUBLE_EQ(m.nocc_pred.bad1, 100.0 * 10 / 180);
  EXPECT_DOUBLE_EQ(m.nocc_pred.bad2, 100.0 * 5 / 180);
  EXPECT_DOUBLE_EQ(m.nocc_pred.bad4, 0.0);
  EXPECT_DOUBLE_EQ(m.nocc_pred.avgerr, (5 * 1.5 + 5 * 3) / 180.0);
}

TEST(Metrics, StepEdgeOcclusionErrors) {
  const GroundTruth gt = step_edge_gt();
  const SceneMetrics m = evaluate_disparity("step", shifted_prediction(gt).view(), gt);
  for (const double plane : m.planes) EXPECT_DOUBLE_EQ(plane, 15.0);
  // Wrong side: column 3 (10 px) plus the 10 missing predictions.
  EXPECT_DOUBLE_EQ(m.occ_err, 100.0 * 20 / 200);
  EXPECT_DOUBLE_EQ(m.occ_err_pred, 100.0 * 10 / 190);
  // The band (columns 0..6) holds column 3 but not the missing column 19.
  EXPECT_DOUBLE_EQ(m.band_err, 100.0 * 10 / 70);
  EXPECT_DOUBLE_EQ(m.band_err_pred, 100.0 * 10 / 70);
  // Column 3 takes the foreground's disparity: the foreground is fattened, nothing thinned.
  EXPECT_DOUBLE_EQ(m.band_front, 100.0 * 10 / 70);
  EXPECT_DOUBLE_EQ(m.band_behind, 0.0);
  // The step is a depth edge and the whole band lies within 3 px of it.
  EXPECT_DOUBLE_EQ(m.band_edge, m.band_err);
  EXPECT_DOUBLE_EQ(m.band_surface, 0.0);
}

// A dense map filled in where its sparse map had holes: the error splits by where it was made.
TEST(Metrics, TheSparseMapSplitsTheErrorIntoMatchedAndFilledPixels) {
  constexpr int w = 20, h = 10;
  GroundTruth gt;
  gt.disparity.resize(w, h);
  Image<float> dense(w, h), sparse(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      gt.disparity.at(x, y) = 10.0f;
      const bool matched = x < 15;  // the matcher left columns 15..19 empty
      sparse.at(x, y) = matched ? 10.0f : std::numeric_limits<float>::infinity();
      // One matched column 3 px off; the fill 5 px off on four of its five columns.
      dense.at(x, y) = x == 2 ? 13.0f : (x >= 16 ? 15.0f : 10.0f);
    }
  const SceneMetrics m = evaluate_disparity("filled", dense.view(), gt, sparse.view());
  EXPECT_TRUE(m.has_matches);
  EXPECT_DOUBLE_EQ(m.filled, 25.0);
  EXPECT_EQ(m.matched.pixels, 150);
  EXPECT_DOUBLE_EQ(m.matched.bad2, 100.0 * 10 / 150);
  EXPECT_EQ(m.filled_err.pixels, 50);
  EXPECT_DOUBLE_EQ(m.filled_err.bad2, 80.0);
  EXPECT_DOUBLE_EQ(m.all.bad2, 100.0 * 50 / 200);  // the same pixels, counted once

  const SceneMetrics plain = evaluate_disparity("filled", dense.view(), gt);
  EXPECT_FALSE(plain.has_matches);
  EXPECT_TRUE(std::isnan(plain.filled));
  EXPECT_TRUE(std::isnan(plain.filled_err.bad2));
  const std::vector<SceneMetrics> both = {m, plain};
  EXPECT_DOUBLE_EQ(mean_metrics(both).filled, 25.0);  // over the scenes that have it

  const Image<float> smaller(w - 1, h);
  EXPECT_THROW(evaluate_disparity("filled", dense.view(), gt, smaller.view()), Error);
}

// The band error splits the same way: column 3, the fattened one, has a match on rows 0..3 only.
TEST(Metrics, TheSparseMapSplitsTheBandErrorIntoMatchedAndFilledPixels) {
  const GroundTruth gt = step_edge_gt();
  const Image<float> pred = shifted_prediction(gt);
  Image<float> sparse(kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) sparse.at(x, y) = x == 3 && y >= 4 ? kInf : pred.at(x, y);
  const SceneMetrics m = evaluate_disparity("step", pred.view(), gt, sparse.view());
  EXPECT_DOUBLE_EQ(m.band_err, 100.0 * 10 / 70);
  EXPECT_DOUBLE_EQ(m.band_matched, 100.0 * 4 / 70);
  EXPECT_DOUBLE_EQ(m.band_filled, 100.0 * 6 / 70);

  // The missing predictions of column 19 lie outside the band; moved into it (column 5), they
  // count as wrong where the sparse map has no value there.
  Image<float> holes = pred;
  for (int y = 0; y < kH; ++y) holes.at(5, y) = kInf;
  sparse.at(5, 0) = kInf;
  const SceneMetrics h = evaluate_disparity("step", holes.view(), gt, sparse.view());
  EXPECT_DOUBLE_EQ(h.band_err, 100.0 * 20 / 70);
  EXPECT_DOUBLE_EQ(h.band_matched, 100.0 * (4 + 9) / 70);
  EXPECT_DOUBLE_EQ(h.band_filled, 100.0 * (6 + 1) / 70);

  const SceneMetrics plain = evaluate_disparity("step", pred.view(), gt);
  EXPECT_TRUE(std::isnan(plain.band_matched));
  EXPECT_TRUE(std::isnan(plain.band_filled));
  const std::vector<SceneMetrics> both = {m, plain};
  const SceneMetrics mean = mean_metrics(both);
  EXPECT_DOUBLE_EQ(mean.band_matched, m.band_matched);  // over the scenes that have it
  EXPECT_DOUBLE_EQ(mean.band_filled, m.band_filled);
}

// A ramp (0.2 px of disparity per column: no depth edge) with a foreground block beside it. The
// prediction is the ramp 1 px too near, so every plane crosses it 5 columns early, and the block
// fattened by one column onto the ramp.
TEST(Metrics, BandErrorSplitsIntoDepthEdgesAndSurfaceCrossings) {
  constexpr int w = 60, h = 8, block = 50;
  GroundTruth gt;
  gt.disparity.resize(w, h);
  Image<float> pred(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      gt.disparity.at(x, y) = x < block ? 10.0f + 0.2f * static_cast<float>(x) : 40.0f;
      pred.at(x, y) = x < block - 1 ? gt.disparity.at(x, y) + 1.0f : 40.0f;
    }
  const SceneMetrics m = evaluate_disparity("ramp", pred.view(), gt);
  EXPECT_GT(m.band_edge, 0.0);
  EXPECT_GT(m.band_surface, 0.0);
  EXPECT_NEAR(m.band_edge + m.band_surface, m.band_err, 1e-9);

  // Without the block there is no depth edge: all of the band error is surface crossings.
  for (int y = 0; y < h; ++y)
    for (int x = block - 1; x < w; ++x) {
      gt.disparity.at(x, y) = 10.0f + 0.2f * static_cast<float>(x);
      pred.at(x, y) = gt.disparity.at(x, y) + 1.0f;
    }
  const SceneMetrics ramp = evaluate_disparity("ramp only", pred.view(), gt);
  EXPECT_GT(ramp.band_err, 0.0);
  EXPECT_DOUBLE_EQ(ramp.band_edge, 0.0);
  EXPECT_DOUBLE_EQ(ramp.band_surface, ramp.band_err);
}

TEST(Metrics, BandIsASevenBySevenDilationOfTheBoundary) {
  // One foreground pixel in the middle of a 21x21 background: boundary = it and its 4 neighbours,
  // band = their 7x7 dilation, a 9x9 square without its 4 corner pixels.
  constexpr int n = 21, c = 10;
  GroundTruth gt;
  gt.disparity.resize(n, n);
  gt.disparity.fill(10.0f);
  gt.disparity.at(c, c) = 30.0f;
  // A prediction that puts everything behind: only the foreground pixel is on the wrong side.
  Image<float> pred(n, n);
  pred.fill(10.0f);
  const SceneMetrics m = evaluate_disparity("dot", pred.view(), gt);
  for (const double plane : m.planes) EXPECT_DOUBLE_EQ(plane, 20.0);
  int band = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int dx = std::abs(x - c), dy = std::abs(y - c);
      // Within Chebyshev 3 of one of (c,c), (c±1,c), (c,c±1).
      const bool in_band = (dx <= 4 && dy <= 3) || (dx <= 3 && dy <= 4);
      band += in_band;
    }
  ASSERT_EQ(band, 9 * 7 + 2 * 7);
  EXPECT_DOUBLE_EQ(m.band_err, 100.0 / band);
  // The foreground pixel predicted behind: virtual content would show through it.
  EXPECT_DOUBLE_EQ(m.band_behind, 100.0 / band);
  EXPECT_DOUBLE_EQ(m.band_front, 0.0);
  EXPECT_DOUBLE_EQ(m.occ_err, 100.0 / (n * n));
}

TEST(Metrics, PerfectPredictionScoresZeroAndIgnoresUnknownGt) {
  GroundTruth gt = step_edge_gt();
  gt.nocc = {};
  Image<float> pred = gt.disparity;
  for (int y = 0; y < kH; ++y) {
    gt.disparity.at(5, y) = kInf;  // no GT: neither counted nor judged
    pred.at(5, y) = 99.0f;
  }
  const SceneMetrics m = evaluate_disparity("perfect", pred.view(), gt);
  EXPECT_EQ(m.gt_pixels, 190);
  EXPECT_DOUBLE_EQ(m.density, 100.0);
  EXPECT_DOUBLE_EQ(m.all.bad1, 0.0);
  EXPECT_DOUBLE_EQ(m.all.avgerr, 0.0);
  EXPECT_DOUBLE_EQ(m.pred.bad4, 0.0);
  EXPECT_DOUBLE_EQ(m.occ_err, 0.0);
  EXPECT_DOUBLE_EQ(m.band_err, 0.0);
  EXPECT_FALSE(m.has_nocc);
  EXPECT_TRUE(std::isnan(m.nocc.bad2));
  EXPECT_TRUE(std::isnan(m.time_ms));
}

TEST(Metrics, NoPredictionAtAll) {
  const GroundTruth gt = step_edge_gt();
  Image<float> pred(kW, kH);
  pred.fill(kInf);
  const SceneMetrics m = evaluate_disparity("empty", pred.view(), gt);
  EXPECT_DOUBLE_EQ(m.density, 0.0);
  EXPECT_DOUBLE_EQ(m.all.bad1, 100.0);
  EXPECT_DOUBLE_EQ(m.all.avgerr, (30 * 20 + 170 * 10) / 200.0);
  EXPECT_DOUBLE_EQ(m.occ_err, 100.0);
  EXPECT_DOUBLE_EQ(m.band_err, 100.0);
  EXPECT_EQ(m.pred.pixels, 0);
  EXPECT_TRUE(std::isnan(m.pred.bad2));
  EXPECT_TRUE(std::isnan(m.occ_err_pred));
  EXPECT_TRUE(std::isnan(m.band_err_pred));
}

TEST(Metrics, PlanesSitBetweenQuantileAndNextGtValue) {
  // Ten pixels each of disparity 1..10: nearest-rank quantiles 2, 4, 5, 7, 8. A last row without
  // GT (inf, NaN, 0, negative) must not move them.
  Image<float> gt(10, 11);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) gt.at(x, y) = static_cast<float>(y + 1);
  const float unknown[] = {kInf, kNaN, 0.0f, -3.0f};
  for (int x = 0; x < 10; ++x) gt.at(x, 10) = unknown[x % 4];
  const auto planes = occlusion_planes(gt.view());
  EXPECT_DOUBLE_EQ(planes[0], 2.5);
  EXPECT_DOUBLE_EQ(planes[1], 4.5);
  EXPECT_DOUBLE_EQ(planes[2], 5.5);
  EXPECT_DOUBLE_EQ(planes[3], 7.5);
  EXPECT_DOUBLE_EQ(planes[4], 8.5);
}

// When a quantile is the largest GT value there is nothing above it: the plane goes halfway to the
// next smaller value, so the pixels at the largest value are in front of it, not on it.
TEST(Metrics, APlaneAtTheLargestValueSitsBelowIt) {
  GroundTruth gt;
  gt.disparity.resize(10, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) gt.disparity.at(x, y) = y < 4 ? 10.0f : 20.0f;
  const auto planes = occlusion_planes(gt.disparity.view());
  EXPECT_DOUBLE_EQ(planes[0], 15.0);  // 10, the 20 % quantile, and the next value above
  for (std::size_t i = 2; i < planes.size(); ++i) EXPECT_DOUBLE_EQ(planes[i], 15.0) << i;
  Image<float> pred(10, 10);
  pred.copy_from(gt.disparity.view());
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) pred.at(x, y) += 0.01f;  // far below any error threshold
  EXPECT_DOUBLE_EQ(evaluate_disparity("two", pred.view(), gt).occ_err, 0.0);
}

// One surface only: no depth edge to put a plane in. A plane on the surface itself would count
// an error of 0.01 px as the wrong side everywhere; the occlusion metrics are undefined instead.
TEST(Metrics, ConstantGtHasNoPlanes) {
  GroundTruth gt;
  gt.disparity.resize(8, 8);
  gt.disparity.fill(12.0f);
  Image<float> pred(8, 8);
  pred.fill(12.01f);
  const SceneMetrics m = evaluate_disparity("flat", pred.view(), gt);
  for (const double plane : m.planes) EXPECT_TRUE(std::isnan(plane)) << plane;
  EXPECT_TRUE(std::isnan(m.occ_err));
  EXPECT_TRUE(std::isnan(m.band_err));
  EXPECT_DOUBLE_EQ(m.all.bad1, 0.0);
}

TEST(Metrics, NoGtAtAllLeavesEverythingUndefined) {
  GroundTruth gt;
  gt.disparity.resize(4, 4);
  gt.disparity.fill(kInf);
  Image<float> pred(4, 4);
  pred.fill(5.0f);
  const SceneMetrics m = evaluate_disparity("none", pred.view(), gt);
  EXPECT_EQ(m.gt_pixels, 0);
  EXPECT_TRUE(std::isnan(m.density));
  EXPECT_TRUE(std::isnan(m.all.bad2));
  EXPECT_TRUE(std::isnan(m.planes[0]));
  EXPECT_TRUE(std::isnan(m.occ_err));
}

TEST(Metrics, RejectsMismatchedPredictions) {
  const GroundTruth gt = step_edge_gt();
  Image<float> small(kW - 1, kH);
  small.fill(10.0f);
  EXPECT_THROW(evaluate_disparity("x", small.view(), gt), Error);
  Image<float> rgb(kW, kH, 3);
  rgb.fill(10.0f);
  EXPECT_THROW(evaluate_disparity("x", rgb.view(), gt), Error);
}

TEST(Metrics, AcceptsStridedViews) {
  const GroundTruth gt = step_edge_gt();
  Image<float> big(kW + 5, kH + 3);
  big.fill(kNaN);
  const Image<float> pred = shifted_prediction(gt);
  const ImageView<float> inner = big.view().sub(2, 1, kW, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) inner.at(x, y) = pred.at(x, y);
  const SceneMetrics a = evaluate_disparity("a", ImageView<const float>(inner), gt);
  const SceneMetrics b = evaluate_disparity("b", pred.view(), gt);
  EXPECT_DOUBLE_EQ(a.all.avgerr, b.all.avgerr);
  EXPECT_DOUBLE_EQ(a.band_err, b.band_err);
}

TEST(Metrics, MeanIsUnweightedAndSkipsUndefinedNumbers) {
  SceneMetrics a, b;
  a.gt_pixels = 100, b.gt_pixels = 300;
  a.predicted_pixels = 100, b.predicted_pixels = 0;
  a.density = 100, b.density = 0;
  a.all = {100, 10, 5, 1, 0.5};
  b.all = {300, 30, 15, 3, 1.5};
  a.pred = {100, 10, 5, 1, 0.5};  // b predicted nothing: its pred numbers stay NaN
  a.has_nocc = true;
  a.nocc = {80, 8, 4, 2, 0.25};
  a.occ_err = 4, b.occ_err = 8;
  a.band_err = 10;  // b has no band
  a.time_ms = 12;   // b's time unknown for now

  const std::vector<SceneMetrics> scenes = {a, b};
  const SceneMetrics mean = mean_metrics(scenes);
  EXPECT_EQ(mean.scene, "mean");
  EXPECT_EQ(mean.gt_pixels, 400);
  EXPECT_EQ(mean.predicted_pixels, 100);
  EXPECT_DOUBLE_EQ(mean.density, 50);
  EXPECT_EQ(mean.all.pixels, 400);
  EXPECT_DOUBLE_EQ(mean.all.bad1, 20);
  EXPECT_DOUBLE_EQ(mean.all.bad2, 10);
  EXPECT_DOUBLE_EQ(mean.all.bad4, 2);
  EXPECT_DOUBLE_EQ(mean.all.avgerr, 1.0);
  EXPECT_DOUBLE_EQ(mean.pred.bad2, 5);
  EXPECT_TRUE(mean.has_nocc);
  EXPECT_DOUBLE_EQ(mean.nocc.bad1, 8);
  EXPECT_DOUBLE_EQ(mean.occ_err, 6);
  EXPECT_DOUBLE_EQ(mean.band_err, 10);
  EXPECT_TRUE(std::isnan(mean.band_err_pred));
  EXPECT_TRUE(std::isnan(mean.time_ms));  // b was not timed: no partial mean
  EXPECT_TRUE(std::isnan(mean.planes[0]));

  b.time_ms = 20;
  const std::vector<SceneMetrics> timed = {a, b};
  EXPECT_DOUBLE_EQ(mean_metrics(timed).time_ms, 16);
}

TEST(Metrics, MeanOfEvaluatedScenes) {
  const GroundTruth gt = step_edge_gt();
  const std::vector<SceneMetrics> scenes = {
      evaluate_disparity("shifted", shifted_prediction(gt).view(), gt),
      evaluate_disparity("perfect", gt.disparity.view(), gt)};
  const SceneMetrics mean = mean_metrics(scenes);
  EXPECT_DOUBLE_EQ(mean.density, (95.0 + 100.0) / 2);
  EXPECT_DOUBLE_EQ(mean.all.bad2, (12.5 + 0.0) / 2);
  EXPECT_DOUBLE_EQ(mean.occ_err, (10.0 + 0.0) / 2);
  EXPECT_DOUBLE_EQ(mean.band_err, (100.0 * 10 / 70 + 0.0) / 2);
}

}  // namespace
}  // namespace dco::tools
