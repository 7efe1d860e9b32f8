// The densifier's match planes: matches smoothed along the plane of their window, left alone at
// depth edges and where the stage decided pixels apart at the input resolution.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/densify/match_planes.hpp"

namespace dco::densify {
namespace {

constexpr float kNone = std::numeric_limits<float>::infinity();

float slope(int x, int y) {
  return 40.0f + 0.3f * static_cast<float>(x) - 0.2f * static_cast<float>(y);
}

// A slanted plane sampled with noise, a pixel in five a hole.
struct NoisyPlane {
  Image<float> truth{64, 48}, sparse{64, 48};
  explicit NoisyPlane(float noise) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> jitter(-noise, noise);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        truth.row(y)[x] = slope(x, y);
        sparse.row(y)[x] = rng() % 5 == 0 ? kNone : truth.row(y)[x] + jitter(rng);
      }
  }
};

double rms_error(ImageView<const float> d, ImageView<const float> truth, int margin) {
  double sum = 0;
  int n = 0;
  for (int y = margin; y < d.height - margin; ++y)
    for (int x = margin; x < d.width - margin; ++x)
      if (d.row(y)[x] < kNone) {
        const double e = d.row(y)[x] - truth.row(y)[x];
        sum += e * e, ++n;
      }
  return std::sqrt(sum / n);
}

TEST(MatchPlanes, SmoothTheNoiseOfASlantedSurfaceAndKeepTheHoles) {
  const NoisyPlane p(0.3f);
  Image<float> out(64, 48);
  MatchPlaneSmoother smoother;
  smoother.apply(p.sparse.cview(), 1, 3, 0.6f, out.view());
  const double before = rms_error(p.sparse.cview(), p.truth.cview(), 3);
  const double after = rms_error(out.cview(), p.truth.cview(), 3);
  EXPECT_GT(before, 0.15);
  EXPECT_LT(after, before / 3);  // about 39 matches per window
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      EXPECT_EQ(out.row(y)[x] < kNone, p.sparse.row(y)[x] < kNone) << x << "," << y;
}

TEST(MatchPlanes, FindTheRangeWhereOnlyRowsBetweenTheSampledOnesHaveMatches) {
  // The disparity range is read from every eighth row first; here those rows have no match.
  NoisyPlane p(0.3f);
  for (int y = 0; y < 48; y += 8)
    for (int x = 0; x < 64; ++x) p.sparse.row(y)[x] = kNone;
  Image<float> out(64, 48);
  MatchPlaneSmoother smoother;
  smoother.apply(p.sparse.cview(), 1, 3, 0.6f, out.view());
  EXPECT_LT(rms_error(out.cview(), p.truth.cview(), 3),
            rms_error(p.sparse.cview(), p.truth.cview(), 3) / 3);
}

TEST(MatchPlanes, LeaveDepthEdgesAndRoughWindowsAlone) {
  // Two slanted surfaces 6 px apart, left and right of column 32: no window across the edge fits
  // one plane within 0.6 px, so every match within 3 columns of it keeps its value exactly.
  NoisyPlane p(0.1f);
  for (int y = 0; y < 48; ++y)
    for (int x = 32; x < 64; ++x)
      if (p.sparse.row(y)[x] < kNone) p.sparse.row(y)[x] += 6.0f;
  Image<float> out(64, 48);
  MatchPlaneSmoother smoother;
  smoother.apply(p.sparse.cview(), 1, 3, 0.6f, out.view());
  int changed_far = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      if (x >= 29 && x <= 34) {
        EXPECT_EQ(out.row(y)[x], p.sparse.row(y)[x]) << x << "," << y;
      }
      if ((x < 26 || x > 37) && out.row(y)[x] != p.sparse.row(y)[x]) ++changed_far;
    }
  EXPECT_GT(changed_far, 1000);
  // A bound of 0.02 px RMS rejects windows with noise of ±0.1 px: nothing changes.
  smoother.apply(p.sparse.cview(), 1, 3, 0.02f, out.view());
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) EXPECT_EQ(out.row(y)[x], p.sparse.row(y)[x]);
}

TEST(MatchPlanes, WorkOnTheMatchersGridAndKeepPixelsDecidedApart) {
  // A half-size map expanded to 2x2 blocks, one input pixel of some blocks given another value
  // (as the boundary refinement does): the blocks' other pixels take the grid's plane value, the
  // odd pixel keeps its own.
  const NoisyPlane p(0.3f);
  Image<float> input(128, 96);
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 128; ++x) input.row(y)[x] = p.sparse.row(y / 2)[x / 2];
  input.row(41)[61] = 7.0f;  // block (30, 20)
  ASSERT_LT(p.sparse.row(20)[30], kNone);
  Image<float> grid_out(64, 48), out(128, 96);
  MatchPlaneSmoother smoother;
  smoother.apply(p.sparse.cview(), 1, 3, 0.6f, grid_out.view());
  smoother.apply(input.cview(), 2, 3, 0.6f, out.view());
  EXPECT_EQ(out.row(41)[61], 7.0f);
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 128; ++x) {
      if (y == 41 && x == 61) continue;
      const float g = grid_out.row(y / 2)[x / 2];
      EXPECT_TRUE(out.row(y)[x] == g || (std::isinf(g) && std::isinf(out.row(y)[x])))
          << x << "," << y;
    }
}

TEST(MatchPlanes, DensifierRejectsABadWindowAndGrid) {
  DensifyParams p;
  p.plane_window = 6;
  EXPECT_THROW(validate(p), Error);
  p.plane_window = 33;
  EXPECT_THROW(validate(p), Error);
  p.plane_window = 0;
  EXPECT_NO_THROW(validate(p));
  p.plane_window = 7;
  p.plane_rms = 0;
  EXPECT_THROW(validate(p), Error);
  Densifier densifier(DensifyParams{});
  Image<float> sparse(16, 8), dense;
  sparse.fill(10.0f);
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.match_step = 0;
  EXPECT_THROW(densifier.compute(in, dense), Error);
}

}  // namespace
}  // namespace dco::densify
