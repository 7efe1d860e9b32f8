// The densify stage against a direct sparse solve of Eq. 20 assembled independently with Eigen,
// and its behaviour on images whose answer is known by construction.

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "../support/same_bytes.hpp"
#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/pipeline/densify/conjugate_gradients.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/densify/multigrid.hpp"
#include "dco/pipeline/densify/sweep_rows.hpp"
#include "dco/pipeline/densify/system_solver.hpp"
#include "kernels/occlusion_reference.hpp"

namespace dco::densify {
namespace {

constexpr float kUnknown = std::numeric_limits<float>::infinity();

struct Problem {
  Image<float> sparse, m_fuse, m_intensity, previous;
  Image<std::uint8_t> contours, image;
};

Problem random_problem(int w, int h, unsigned seed, double density) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  Problem p;
  p.sparse.resize(w, h);
  p.m_fuse.resize(w, h);
  p.m_intensity.resize(w, h);
  p.previous.resize(w, h);
  p.contours.resize(w, h);
  p.image.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      p.sparse.at(x, y) = unit(rng) < density ? 5.0f + 30.0f * unit(rng) : kUnknown;
      p.m_fuse.at(x, y) = unit(rng);
      p.m_intensity.at(x, y) = unit(rng);
      p.previous.at(x, y) = unit(rng) < 0.8f ? 5.0f + 30.0f * unit(rng) : 0.0f;
      p.contours.at(x, y) = unit(rng) < 0.1f ? 255 : 0;
      p.image.at(x, y) = static_cast<std::uint8_t>(unit(rng) * 40.0f);
    }
  return p;
}

// A near surface left of column `edge` and a far one from it on, a contour on that column, and
// sparse values where known(x, y).
struct TwoSurfaces {
  Image<float> sparse;
  Image<std::uint8_t> contours;
  DensifyInputs inputs() const {
    DensifyInputs in;
    in.sparse = sparse.cview();
    in.contours = contours.cview();
    return in;
  }
};

template <class Known>
TwoSurfaces two_surfaces(int w, int h, int edge, float near, float far, Known known) {
  TwoSurfaces t{Image<float>(w, h), Image<std::uint8_t>(w, h)};
  t.contours.fill(0);
  for (int y = 0; y < h; ++y) {
    t.contours.at(edge, y) = 255;
    for (int x = 0; x < w; ++x)
      t.sparse.at(x, y) = known(x, y) ? (x < edge ? near : far) : kUnknown;
  }
  return t;
}

// Eq. 20 assembled from its definition: E = λd Σ w_sparse (D - Ds)^2
//   + λs Σ_p Σ_{q∈N4(p)} w_pq (D_p - D_q)^2 + λs2 Σ w_stable (D - Dpre)^2,
// with dco's two additions: w_pq scaled by exp(-|I_p - I_q| / color_sigma), and holes pulled
// with weight background_fill * λd towards the smaller of the nearest known values on their row
// (but for the holes occlusion_far says drop it), and occlusion strips (occlusion_far, the few
// matches inside one included) also with weight occlusion_fill * λd to their far side.
float row_hint(const Image<float>& sparse, int x, int y) {
  float left = 0, right = 0;
  for (int i = x; i >= 0; --i)
    if (std::isfinite(sparse.at(i, y)) && sparse.at(i, y) > 0) {
      left = sparse.at(i, y);
      break;
    }
  for (int i = x; i < sparse.width(); ++i)
    if (std::isfinite(sparse.at(i, y)) && sparse.at(i, y) > 0) {
      right = sparse.at(i, y);
      break;
    }
  if (left <= 0) return right;
  if (right <= 0) return left;
  return std::min(left, right);
}

// The occlusion strips' pull of one pixel (kernels::occlusion_fill_row, its rule restated in
// kernels/occlusion_reference.hpp): the far value it is pulled to with weight occlusion_fill * λd,
// kernels::kNoHint for a hole that drops its hole hint, or 0.
float occlusion_far(const Image<float>& sparse, int x, int y, const DensifyParams& params) {
  const std::vector<float> row(sparse.row(y), sparse.row(y) + sparse.width());
  return kernels::occlusion_targets(row, nullptr,
                                    params.occlusion_fill > 0)[static_cast<std::size_t>(x)];
}

Eigen::VectorXd direct_solution(const Problem& pr, const DensifyParams& params) {
  const int w = pr.sparse.width(), h = pr.sparse.height();
  Image<std::uint8_t> barrier(w, h);
  close_diagonal_gaps(pr.contours.cview(), barrier.view());
  const auto idx = [w](int x, int y) { return y * w + x; };
  const auto strength = [&](int x, int y) { return pr.m_fuse.at(x, y) * pr.m_intensity.at(x, y); };
  std::vector<Eigen::Triplet<double>> t;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(w * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double diag = 1e-6;  // the densifier's regulariser
      const float s = pr.sparse.at(x, y);
      if (std::isfinite(s) && s > 0) {
        diag += params.lambda_d;
        b[idx(x, y)] += params.lambda_d * s;
      } else if (const float hint = row_hint(pr.sparse, x, y);
                 hint > 0 && occlusion_far(pr.sparse, x, y, params) != kernels::kNoHint) {
        diag += params.lambda_d * params.background_fill;
        b[idx(x, y)] += params.lambda_d * params.background_fill * hint;
      }
      if (const float far = occlusion_far(pr.sparse, x, y, params); far > 0) {
        diag += params.lambda_d * params.occlusion_fill;
        b[idx(x, y)] += params.lambda_d * params.occlusion_fill * far;
      }
      const float prev = pr.previous.at(x, y);
      if (prev > 0) {
        diag += params.lambda_s2;
        b[idx(x, y)] += params.lambda_s2 * prev;
      }
      t.emplace_back(idx(x, y), idx(x, y), diag);
      const int nx[4] = {x + 1, x - 1, x, x};
      const int ny[4] = {y, y, y + 1, y - 1};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
        double wpq;
        if ((barrier.at(x, y) != 0) != (barrier.at(nx[k], ny[k]) != 0))
          wpq = params.min_edge_weight;
        else
          wpq = std::max((1.0 - std::min(strength(x, y), strength(nx[k], ny[k]))) *
                             std::exp(-std::abs(pr.image.at(x, y) - pr.image.at(nx[k], ny[k])) /
                                      params.color_sigma),
                         params.min_edge_weight);
        // d/dD_p of λs w (D_p - D_q)^2 appears once from p's sum and once from q's sum.
        t.emplace_back(idx(x, y), idx(x, y), 2 * params.lambda_s * wpq);
        t.emplace_back(idx(x, y), idx(nx[k], ny[k]), -2 * params.lambda_s * wpq);
      }
    }
  Eigen::SparseMatrix<double> a(w * h, w * h);
  a.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(a);
  EXPECT_EQ(solver.info(), Eigen::Success);
  return solver.solve(b);
}

DensifyInputs inputs_of(const Problem& p) {
  DensifyInputs in;
  in.sparse = p.sparse.cview();
  in.m_fuse = p.m_fuse.cview();
  in.m_intensity = p.m_intensity.cview();
  in.contours = p.contours.cview();
  in.previous = p.previous.cview();
  in.image = p.image.cview();
  return in;
}

// The system the densifier builds for random_problem(w, h, seed, 0.3).
GridSystem random_system(int w, int h, unsigned seed) {
  const Problem p = random_problem(w, h, seed, 0.3);
  Densifier d(DensifyParams{});
  Image<float> dense;
  d.compute(inputs_of(p), dense);
  return d.last_system();
}

class DensifierVsDirectSolve : public ::testing::TestWithParam<bool> {};

TEST_P(DensifierVsDirectSolve, MatchesEigenOnRandomProblems) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Problem p = random_problem(37, 29, seed, 0.3);
    DensifyParams params;
    params.multigrid = GetParam();
    // A floor well above the default keeps the random contours from isolating pixels, so the
    // condition number lets a single-precision residual of 1e-6 pin the solution to 1e-3.
    params.min_edge_weight = 0.05;
    params.tolerance = 1e-6;
    params.max_iterations = 2000;
    Densifier d(params);
    Image<float> dense;
    d.compute(inputs_of(p), dense);
    EXPECT_TRUE(d.last_report().converged) << d.last_report().final_residual;
    const Eigen::VectorXd ref = direct_solution(p, params);
    // The solution itself; the output is its median (median_size).
    const ImageView<const float> solution = d.last_solution();
    double worst = 0;
    for (int y = 0; y < 29; ++y)
      for (int x = 0; x < 37; ++x)
        worst = std::max(worst, std::abs(solution.row(y)[x] - ref[y * 37 + x]));
    EXPECT_LT(worst, 1e-3) << "seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(WithAndWithoutMultigrid, DensifierVsDirectSolve, ::testing::Bool());

TEST(Densifier, MultigridNeedsFarFewerIterationsThanPlainCg) {
  const Problem p = random_problem(200, 150, 4, 0.05);
  DensifyParams params;
  params.max_iterations = 5000;
  params.tolerance = 1e-5;
  Densifier with(params);
  params.multigrid = false;
  Densifier without(params);
  Image<float> a, b;
  with.compute(inputs_of(p), a);
  without.compute(inputs_of(p), b);
  ASSERT_TRUE(with.last_report().converged);
  ASSERT_TRUE(without.last_report().converged);
  EXPECT_LT(with.last_report().iterations * 4, without.last_report().iterations);
}

TEST(Densifier, FillsEveryPixelAndKeepsAPlaneWhereDataIsExact) {
  // Sparse samples of an affine disparity d = 10 + 0.05 x + 0.02 y: inside the image the
  // smoothness term is zero-gradient for an affine map, so the fill reproduces the plane; only
  // the image border (fewer neighbours) pulls a little.
  const int w = 64, h = 48;
  Image<float> sparse(w, h);
  std::mt19937 rng(5);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      sparse.at(x, y) = (rng() % 4 == 0 || x == 0 || y == 0 || x == w - 1 || y == h - 1)
                            ? 10.0f + 0.05f * x + 0.02f * y
                            : kUnknown;
  DensifyParams params;
  params.background_fill = 0;  // the paper's model: holes follow the smoothness term alone
  params.occlusion_fill = 0;
  params.tolerance = 1e-6;
  params.max_iterations = 500;
  Densifier d(params);
  DensifyInputs in;
  in.sparse = sparse.cview();
  Image<float> dense;
  d.compute(in, dense);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool interior = x >= 10 && y >= 10 && x < w - 10 && y < h - 10;
      ASSERT_NEAR(dense.at(x, y), 10.0f + 0.05f * x + 0.02f * y, interior ? 0.01 : 0.15)
          << x << "," << y;
    }
}

// A library caller's sparse map with disparities no image has (1e22, 1e30: finite, but past what
// the solver's float sums hold): an error, never a "dense" map of NaN, and the next frame, with
// sane values, is solved from scratch rather than from the failed one.
TEST(Densifier, DisparitiesPastAnyImagesAreAnErrorNotAMapOfNaN) {
  const int w = 32, h = 16;
  Image<float> sparse(w, h), sane(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      sparse.at(x, y) = x < w / 2 ? 1e22f : 5.0f;
      sane.at(x, y) = (x + y) % 3 == 0 ? 5.0f : kUnknown;
    }
  for (const char* r : {"full", "half"}) {
    DensifyParams params;
    params.solve_resolution = r;
    Densifier d(params);
    DensifyInputs in;
    in.sparse = sparse.cview();
    Image<float> dense;
    EXPECT_THROW(d.compute(in, dense), Error);
    in.sparse = sane.cview();
    d.compute(in, dense);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_NEAR(dense.at(x, y), 5.0f, 0.01f) << x << "," << y;
  }
}

// A contour strength that is not finite, at a pixel whose edges the half-size solve folds inside
// its 2x2 block: the full-size steps after that solve met it, and the output held NaN while the
// coarse residual said the solve was fine. Every solve path now says so, and the next frame, with
// clean strengths, starts cold rather than from the failed one.
TEST(Densifier, ANonFiniteContourStrengthIsAnErrorOnEverySolvePath) {
  const int w = 64, h = 48;
  Image<float> sparse(w, h), fuse(w, h), intensity(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sparse.at(x, y) = (x + y) % 3 ? 10.0f + 0.1f * x : kUnknown;
  fuse.fill(0.1f);
  intensity.fill(0.2f);
  for (const char* r : {"full", "half"}) {
    SCOPED_TRACE(r);
    DensifyParams params;
    params.solve_resolution = r;
    Densifier d(params);
    DensifyInputs in;
    in.sparse = sparse.cview();
    in.m_fuse = fuse.cview();
    in.m_intensity = intensity.cview();
    Image<float> dense;
    fuse.at(32, 24) = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(d.compute(in, dense), Error);
    fuse.at(32, 24) = 0.1f;
    in.previous = d.last_solution();
    d.compute(in, dense);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_TRUE(std::isfinite(dense.at(x, y))) << x << "," << y;
  }
}

TEST(Densifier, ContourKeepsTwoSurfacesApart) {
  // Left half near (disparity 40), right half far (10); sparse values only far from the edge,
  // and a contour on the true boundary column: the fill must not blend across it.
  const int w = 60, h = 20, edge = 30;
  const TwoSurfaces scene =
      two_surfaces(w, h, edge, 40.0f, 10.0f, [](int x, int) { return x < 10 || x >= 50; });
  DensifyParams params;
  params.background_fill = 0;
  Densifier d(params);
  DensifyInputs in = scene.inputs();
  Image<float> dense;
  d.compute(in, dense);
  for (int y = 0; y < h; ++y) {
    EXPECT_GT(dense.at(edge - 1, y), 38.0f);
    EXPECT_LT(dense.at(edge + 1, y), 12.0f);
  }
  // Without the contour the same data blends into a ramp.
  Densifier plain(params);
  in.contours = {};
  plain.compute(in, dense);
  EXPECT_LT(dense.at(edge - 1, h / 2), 30.0f);
  EXPECT_GT(dense.at(edge + 1, h / 2), 20.0f);
}

// M_fuse at the half internal resolution of an odd width: cell 10 covers image columns 20 and
// 21, so the smoothness is cut on the edge between them, as for an even width.
TEST(Densifier, AnOddWidthCutsTheSmoothnessWhereItsCueIs) {
  for (const int w : {66, 65}) {
    const int h = 3;
    Image<float> sparse(w, h), fuse(w / 2, 1), intensity(w, h);
    sparse.fill(10.0f);
    intensity.fill(1.0f);
    fuse.fill(0.0f);
    fuse.at(10, 0) = 1.0f;
    DensifyParams p;
    p.plane_window = 0;
    p.solve_resolution = "full";
    Densifier d(p);
    DensifyInputs in;
    in.sparse = sparse.cview();
    in.m_fuse = fuse.cview();
    in.m_intensity = intensity.cview();
    in.match_step = 2;
    Image<float> out;
    d.compute(in, out);
    const GridSystem& a = d.last_system();
    int weakest = 0;
    for (int x = 1; x < w - 1; ++x)
      if (a.wx.at(x, 1) < a.wx.at(weakest, 1)) weakest = x;
    EXPECT_EQ(weakest, 20) << w;
    EXPECT_LT(a.wx.at(20, 1), 0.01f * a.wx.at(19, 1)) << w;
  }
}

TEST(Densifier, HolesBesideAJumpLeanTowardsTheFartherSurface) {
  // A hole between a far surface (10) and a near one (40) on its right, where the left image
  // holds occlusions (too narrow for the near surface's strip): with the background pull the
  // hole takes mostly the far value; without it, the midpoint.
  const int w = 60, h = 10;
  Image<float> sparse(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sparse.at(x, y) = x < 20 ? 10.0f : (x >= 30 ? 40.0f : kUnknown);
  DensifyInputs in;
  in.sparse = sparse.cview();
  Image<float> with_pull, without, mirrored;
  DensifyParams params;
  params.background_fill = 0.2;
  Densifier(params).compute(in, with_pull);
  params.background_fill = 0;
  Densifier(params).compute(in, without);
  EXPECT_LT(with_pull.at(25, 5), without.at(25, 5) - 5.0f);
  EXPECT_NEAR(without.at(25, 5), 25.0f, 2.0f);

  // Mirrored, the near surface on the left: no occlusion lies right of a near surface, so the
  // hole is a matching failure of either side and takes no pull: the midpoint again.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sparse.at(x, y) = x < 20 ? 40.0f : (x >= 30 ? 10.0f : kUnknown);
  params.background_fill = 0.2;
  Densifier(params).compute(in, mirrored);
  EXPECT_NEAR(mirrored.at(25, 5), 25.0f, 2.0f);
}

TEST(Densifier, OcclusionStripsStepAtTheNearSurfacesEdge) {
  // Left of a near surface (30) the left camera sees a strip of the far one (10) that the right
  // camera does not: 20 px wide for a jump of 20 px. The weak hole hint alone lets the smoothness
  // ramp the strip up to the near value; as an occlusion strip it stays on the far surface.
  const int w = 80, h = 10, strip = 30, edge = 50;
  Image<float> sparse(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      sparse.at(x, y) = x < strip ? 10.0f : (x >= edge ? 30.0f : kUnknown);
  DensifyInputs in;
  in.sparse = sparse.cview();
  Image<float> dense, ramp;
  DensifyParams params;
  ASSERT_GT(params.occlusion_fill, 0.0);
  Densifier(params).compute(in, dense);
  params.occlusion_fill = 0;
  Densifier(params).compute(in, ramp);
  // Without image guidance the step still softens over the last pixels before the edge.
  for (int x = strip; x < edge - 3; ++x) EXPECT_NEAR(dense.at(x, h / 2), 10.0f, 0.5f) << "x " << x;
  EXPECT_LT(dense.at(edge - 1, h / 2), 16.0f);
  EXPECT_GT(ramp.at(strip + 10, h / 2), 12.0f);
  EXPECT_GT(ramp.at(edge - 1, h / 2), 22.0f);

  // A run 4 px wider than the jump: its first 20 px are the strip, the last 4 the near surface's
  // unmatched rim, whose first 2 px keep the weak hint and whose last 2 the near side decides.
  for (int y = 0; y < h; ++y)
    for (int x = strip - 4; x < strip; ++x) sparse.at(x, y) = kUnknown;
  params.occlusion_fill = 2;
  Densifier(params).compute(in, dense);
  for (int x = strip - 4; x < edge - 8; ++x)
    EXPECT_NEAR(dense.at(x, h / 2), 10.0f, 0.5f) << "x " << x;
  EXPECT_GT(dense.at(edge - 1, h / 2), 20.0f);

  // A strip much narrower than the jump is no occlusion of this pair: it keeps the ramp.
  for (int y = 0; y < h; ++y)
    for (int x = strip - 4; x < edge - 8; ++x) sparse.at(x, y) = 10.0f;
  Densifier(params).compute(in, dense);
  EXPECT_GT(dense.at(edge - 1, h / 2), 20.0f);
}

TEST(Densifier, TheRimPastAnOcclusionStripJoinsTheNearSurface) {
  // The strip left of a near surface (30, from x = 50) is 20 px wide (far surface 10); on every
  // second row the stereo stage also missed the near surface's first 8 px, so the run is 28 px
  // wide there. A checkerboard image puts every smoothness weight at its floor, below the hole
  // hint's weight: with the hint, those 8 px would follow it to the far side. Past the strip's
  // first 2 px they take no hint, and their matched neighbours above and below decide.
  const int w = 90, h = 12, strip = 30, edge = 50, rim = 8;
  Image<float> sparse(w, h);
  Image<std::uint8_t> image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int near_from = y % 2 == 0 ? edge + rim : edge;
      sparse.at(x, y) = x < strip ? 10.0f : (x >= near_from ? 30.0f : kUnknown);
      image.at(x, y) = static_cast<std::uint8_t>((x + y) % 2 * 255);
    }
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.image = image.cview();
  DensifyParams params;
  // Rims on every second row only: the output's median would remove the hinted ones below too.
  params.median_size = 0;
  Image<float> dense, rim_hinted;
  Densifier(params).compute(in, dense);
  for (int y = 2; y < h - 2; y += 2) {
    for (int x = strip; x < edge - 1; ++x)
      EXPECT_NEAR(dense.at(x, y), 10.0f, 1.0f) << "strip x " << x << " y " << y;
    for (int x = edge + 2; x < edge + rim; ++x)
      EXPECT_GT(dense.at(x, y), 25.0f) << "rim x " << x << " y " << y;
  }
  // The same rim with the hint, as a hole run that holds no strip keeps it: a strip 20 px wider
  // than the jump is none.
  for (int y = 0; y < h; ++y)
    for (int x = strip - 20; x < strip; ++x) sparse.at(x, y) = kUnknown;
  Densifier(params).compute(in, rim_hinted);
  EXPECT_LT(rim_hinted.at(edge + 4, h / 2), 20.0f);
}

TEST(Densifier, OutputMedianRemovesSpecksAndKeepsEdgesWhereTheyAre) {
  // Every pixel matched: 10 left of x = 20 and 30 from it, with a single 30 at (8, 4), a column
  // of 30 one pixel wide at x = 12 (rows 2-7) and a bar of 30 two pixels wide at x = 15-16. A
  // checkerboard image puts every smoothness weight at its floor, so the solution follows the
  // data, specks included.
  const int w = 32, h = 10;
  Image<float> sparse(w, h);
  Image<std::uint8_t> image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool near =
          x >= 20 || x == 15 || x == 16 || (x == 12 && y >= 2 && y <= 7) || (x == 8 && y == 4);
      sparse.at(x, y) = near ? 30.0f : 10.0f;
      image.at(x, y) = static_cast<std::uint8_t>((x + y) % 2 * 255);
    }
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.image = image.cview();
  DensifyParams params;
  params.median_size = 3;
  Densifier d(params);
  Image<float> dense;
  d.compute(in, dense);
  EXPECT_NEAR(dense.at(8, 4), 10.0f, 1.0f) << "speck";
  for (int y = 2; y <= 7; ++y) EXPECT_NEAR(dense.at(12, y), 10.0f, 1.0f) << "column y " << y;
  for (int y = 0; y < h; ++y) {
    EXPECT_GT(dense.at(15, y), 29.0f) << "bar y " << y;
    EXPECT_GT(dense.at(16, y), 29.0f) << "bar y " << y;
    EXPECT_LT(dense.at(19, y), 11.0f) << "step y " << y;
    EXPECT_GT(dense.at(20, y), 29.0f) << "step y " << y;
  }
  // The solution, the next frame's start and previous frame, keeps them.
  EXPECT_GT(d.last_solution().row(4)[8], 29.0f);
  // The 5x5 median (the default) also takes the two-pixel bar and still keeps the step.
  params.median_size = 5;
  ASSERT_EQ(DensifyParams{}.median_size, 5);
  Densifier(params).compute(in, dense);
  for (int y = 0; y < h; ++y) {
    EXPECT_NEAR(dense.at(12, y), 10.0f, 1.0f) << "column y " << y;
    EXPECT_NEAR(dense.at(15, y), 10.0f, 1.0f) << "bar y " << y;
    EXPECT_LT(dense.at(19, y), 11.0f) << "step y " << y;
    EXPECT_GT(dense.at(20, y), 29.0f) << "step y " << y;
  }
  params.median_size = 0;
  Densifier(params).compute(in, dense);
  EXPECT_GT(dense.at(8, 4), 29.0f);
  EXPECT_GT(dense.at(12, 4), 29.0f);
}

TEST(Densifier, OutputMedianOfFiveIsOpenCvsMedianBlurOfTheSolution) {
  // The 5x5 median is a kernel of ours (OpenCV's takes three times as long): the same values
  // as cv::medianBlur, border columns and rows included, on widths that are not whole vectors.
  for (const int w : {5, 37, 70}) {
    const Problem p = random_problem(w, 23, static_cast<unsigned>(w), 0.3);
    DensifyParams params;
    params.median_size = 5;
    Densifier d(params);
    Image<float> dense;
    d.compute(inputs_of(p), dense);
    cv::Mat expected;
    cv::medianBlur(as_mat(d.last_solution()), expected, 5);
    for (int y = 0; y < 23; ++y)
      for (int x = 0; x < w; ++x)
        ASSERT_EQ(dense.at(x, y), expected.at<float>(y, x))
            << "w " << w << " x " << x << " y " << y;
  }
}

// The row-wise steps shared among threads (densify.row_threads) give the bytes of one thread:
// the system, the solve and the output, over two warm-started frames, with each median, with the
// match planes and the border planes, on sizes that do not split evenly.
TEST(Densifier, RowThreadsGiveTheBytesOfOneThread) {
  for (const int median : {0, 3, 5}) {
    for (const auto& [w, h] : {std::pair{97, 61}, std::pair{160, 7}}) {
      Problem first = random_problem(w, h, 11, 0.3);
      Problem second = random_problem(w, h, 12, 0.3);
      DensifyParams params;
      params.median_size = median;
      params.solve_resolution = median == 3 ? "half" : "full";
      params.row_threads = 1;
      Densifier one(params);
      for (const int threads : {2, 3, 4}) {
        params.row_threads = threads;
        Densifier many(params);
        Image<float> expected, actual;
        one.reset();
        for (const Problem* frame : {&first, &second}) {
          DensifyInputs in = inputs_of(*frame);
          in.previous = one.last_solution();
          one.compute(in, expected);
          in.previous = many.last_solution();
          many.compute(in, actual);
          const std::string what = "median " + std::to_string(median) + ", " +
                                   params.solve_resolution + " solve, " + std::to_string(w) + "x" +
                                   std::to_string(h) + ", " + std::to_string(threads) + " threads";
          ASSERT_TRUE(testing::same_bytes(expected, actual)) << what;
          ASSERT_TRUE(testing::same_bytes(one.last_system().data, many.last_system().data)) << what;
          ASSERT_TRUE(testing::same_bytes(one.last_system().wx, many.last_system().wx)) << what;
          ASSERT_TRUE(testing::same_bytes(one.last_system().wy, many.last_system().wy)) << what;
          ASSERT_TRUE(testing::same_bytes(one.last_system().inv_diag, many.last_system().inv_diag))
              << what;
          ASSERT_TRUE(testing::same_bytes(one.last_rhs(), many.last_rhs())) << what;
          EXPECT_EQ(one.last_report().iterations, many.last_report().iterations) << what;
          EXPECT_EQ(one.last_report().final_residual, many.last_report().final_residual) << what;
        }
      }
    }
  }
  // A frame of fewer rows than threads after one of many: the rows all go to the caller, and
  // nothing of the parts that had rows before is left over.
  {
    DensifyParams params;
    params.row_threads = 1;
    Densifier one(params);
    params.row_threads = 8;
    Densifier eight(params);
    Image<float> expected, actual;
    for (const int h : {61, 5}) {
      const Problem p = random_problem(97, h, 20 + static_cast<unsigned>(h), 0.3);
      one.compute(inputs_of(p), expected);
      eight.compute(inputs_of(p), actual);
      EXPECT_TRUE(testing::same_bytes(expected, actual)) << h << " rows";
    }
  }
}

// The CPU solver as it is, but recording whether each system it solved held its diagonal and
// claiming to need it or not as told.
class DiagonalWatch final : public SystemSolver {
 public:
  DiagonalWatch(const DensifyParams& params, bool force, std::vector<bool>& seen)
      : inner_(make_cpu_system_solver(params)), force_(force), seen_(seen) {}
  SolverReport solve(const GridSystem& a, ImageView<const float> b, ImageView<float> x) override {
    seen_.push_back(a.has_diagonal);
    return inner_->solve(a, b, x);
  }
  bool needs_diagonal(int width) const override { return force_ || inner_->needs_diagonal(width); }

 private:
  std::unique_ptr<SystemSolver> inner_;
  bool force_;
  std::vector<bool>& seen_;
};

TEST(Densifier, TheFullSizeDiagonalIsBuiltOnlyForASolveThatReadsIt) {
  // A wide frame solved at half size with full-size sweeps alone: the sweeps work each row's
  // diagonal out as they load it, so the system leaves its two diagonal images out, and the
  // output is the bytes of a build that made them. A full-size solve, full-size iterations
  // after the sweeps, or the output's residual without sweeps (which reads the system's rows
  // as they are) read them: they are built.
  const int w = 700, h = 41;
  const Problem first = random_problem(w, h, 31, 0.3);
  const Problem second = random_problem(w, h, 32, 0.3);
  struct Case {
    std::string resolution;
    int fine_iterations;
    bool built;
    int fine_sweeps = DensifyParams{}.fine_sweeps;
    bool output_residual = false;
  };
  for (const Case& c :
       {Case{"auto", 0, false}, Case{"half", 0, false}, Case{"half", 2, true},
        Case{"full", 0, true}, Case{"half", 0, false, 4, true}, Case{"half", 0, true, 0, true}}) {
    DensifyParams params;
    params.solve_resolution = c.resolution;
    params.fine_iterations = c.fine_iterations;
    params.fine_sweeps = c.fine_sweeps;
    params.output_residual = c.output_residual;
    std::vector<bool> seen, forced_seen;
    Densifier d(params, [&](const DensifyParams& p) {
      return std::make_unique<DiagonalWatch>(p, false, seen);
    });
    Densifier forced(params, [&](const DensifyParams& p) {
      return std::make_unique<DiagonalWatch>(p, true, forced_seen);
    });
    const std::string what = c.resolution + ", " + std::to_string(c.fine_iterations) + " fine, " +
                             std::to_string(c.fine_sweeps) + " sweeps" +
                             (c.output_residual ? ", output residual" : "");
    Image<float> actual, expected;
    for (const Problem* frame : {&first, &second}) {
      DensifyInputs in = inputs_of(*frame);
      in.previous = d.last_solution();
      d.compute(in, actual);
      in.previous = forced.last_solution();
      forced.compute(in, expected);
      ASSERT_TRUE(testing::same_bytes(expected, actual)) << what;
      EXPECT_EQ(d.last_report().final_residual, forced.last_report().final_residual) << what;
      if (c.output_residual) {
        EXPECT_EQ(d.last_report().output_residual, forced.last_report().output_residual) << what;
      }
      // Asked for, the system has its diagonal, the bytes a build would have made.
      const GridSystem& built = forced.last_system();
      const GridSystem& asked = d.last_system();
      ASSERT_TRUE(asked.has_diagonal) << what;
      EXPECT_TRUE(testing::same_bytes(built.diag, asked.diag)) << what;
      EXPECT_TRUE(testing::same_bytes(built.inv_diag, asked.inv_diag)) << what;
    }
    EXPECT_EQ(seen, std::vector<bool>(2, c.built)) << what;
    EXPECT_EQ(forced_seen, std::vector<bool>(2, true)) << what;
  }
}

TEST(Densifier, ImageEdgesWeakenSmoothing) {
  // The same hole, but the image has an edge at x = 25: the fill follows the image edge.
  const int w = 60, h = 10;
  Image<float> sparse(w, h);
  Image<std::uint8_t> image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      sparse.at(x, y) = x < 20 ? 40.0f : (x >= 30 ? 10.0f : kUnknown);
      image.at(x, y) = x < 25 ? 50 : 200;
    }
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.image = image.cview();
  DensifyParams params;
  params.background_fill = 0;
  Image<float> dense;
  Densifier(params).compute(in, dense);
  EXPECT_GT(dense.at(24, 5), 38.0f);
  EXPECT_LT(dense.at(25, 5), 12.0f);
}

TEST(Densifier, HoleInsideAnObjectKeepsTheObjectsDepthNotTheBackgrounds) {
  // The background (grey 200, disparity 10) ends at the image edge between x = 14 and 15; the
  // object (grey 50, disparity 40) starts there. The hole x = 10..19 straddles the edge (too
  // narrow for the strip the object hides): its object part must take the object's value,
  // although the farther neighbour is background.
  const int w = 60, h = 10;
  Image<float> sparse(w, h);
  Image<std::uint8_t> image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      sparse.at(x, y) = x < 10 ? 10.0f : (x >= 20 ? 40.0f : kUnknown);
      image.at(x, y) = x < 15 ? 200 : 50;
    }
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.image = image.cview();
  DensifyParams params;
  ASSERT_GT(params.fill_edge_weight, 0.0);
  Image<float> aware, farther;
  Densifier(params).compute(in, aware);
  for (int x = 10; x < 15; ++x) EXPECT_LT(aware.at(x, 5), 11.0f) << x;
  for (int x = 15; x < 20; ++x) EXPECT_GT(aware.at(x, 5), 39.0f) << x;
  // With the plain "farther neighbour" rule the object's part of the hole sinks towards 10.
  params.fill_edge_weight = 0;
  Densifier(params).compute(in, farther);
  EXPECT_LT(farther.at(15, 5), aware.at(15, 5) - 2.0f);
}

TEST(Densifier, HalfResolutionSolveKeepsAContourOnAnOddColumn) {
  // The contour sits on column 31, inside the 2x2 aggregate of columns 30..31: the aggregated
  // solve blurs that aggregate, and the full-resolution sweeps must put the step back.
  const int w = 64, h = 24, edge = 31;
  const TwoSurfaces scene =
      two_surfaces(w, h, edge, 40.0f, 10.0f, [](int x, int y) { return (x + y) % 3 == 0; });
  const DensifyInputs in = scene.inputs();
  DensifyParams params;
  params.background_fill = 0;
  params.solve_resolution = "full";
  Image<float> full, half;
  Densifier(params).compute(in, full);
  params.solve_resolution = "half";
  params.fine_sweeps = 4;
  params.fine_iterations = 0;
  params.output_residual = true;
  Densifier d(params);
  d.compute(in, half);
  // Without the residual's pass: the same map, and no figure.
  {
    DensifyParams unmeasured = params;
    unmeasured.output_residual = false;
    Densifier u(unmeasured);
    Image<float> same;
    u.compute(in, same);
    EXPECT_TRUE(dco::testing::same_bytes(same.cview(), half.cview()));
    EXPECT_TRUE(std::isnan(u.last_report().output_residual));
    EXPECT_EQ(u.last_report().final_residual, d.last_report().final_residual);
  }
  EXPECT_TRUE(d.last_report().converged);
  EXPECT_EQ(d.last_report().fine_iterations, 0);
  EXPECT_GT(d.last_report().output_residual, 0.0);
  EXPECT_LT(d.last_report().output_residual, 0.1);
  const auto mean_difference = [&](const Image<float>& a) {
    double sum = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) sum += std::abs(a.at(x, y) - full.at(x, y));
    return sum / (w * h);
  };
  for (int y = 0; y < h; ++y)  // the step survives, a little smaller than the full solve's 30
    EXPECT_GT(half.at(edge - 1, y) - half.at(edge + 1, y), 24.0f) << y;
  const double with_sweeps = mean_difference(half);
  EXPECT_LT(with_sweeps, 1.0);
  // Without the sweeps the aggregate that straddles the contour keeps a blend.
  params.fine_sweeps = 0;
  Densifier no_sweeps(params);
  no_sweeps.compute(in, half);
  EXPECT_GT(no_sweeps.last_report().output_residual, d.last_report().output_residual);
  const double without_sweeps = mean_difference(half);
  EXPECT_GT(without_sweeps, with_sweeps);
  // Conjugate-gradient iterations at full size get closer still.
  params.fine_iterations = 2;
  Densifier iterated(params);
  iterated.compute(in, half);
  EXPECT_GE(iterated.last_report().fine_iterations, 1);
  EXPECT_LE(iterated.last_report().fine_iterations, 2);
  EXPECT_LT(iterated.last_report().output_residual, d.last_report().output_residual);
  EXPECT_LT(mean_difference(half), with_sweeps);
  for (int y = 0; y < h; ++y) EXPECT_GT(half.at(edge - 1, y) - half.at(edge + 1, y), 27.0f) << y;
  // The defaults refine as the first run above did: four sweeps, no iteration (each sweep is one
  // pass; an iteration costs a V-cycle over the full-size system).
  const DensifyParams defaults;
  EXPECT_EQ(defaults.fine_sweeps, 4);
  EXPECT_EQ(defaults.fine_iterations, 0);
}

TEST(Densifier, AnEarlyStopStaysWithinTheRangeOfTheData) {
  // A near surface (50) and a far one (5) split by a contour, with small boxes of contour and
  // no data along the split: one iteration leaves the boxes far from converged, and the
  // preconditioner hands them the other surface's correction. The exact solution is a weighted
  // mean of the data, so the output must stay within [5, 50] wherever the solve stops.
  const int w = 96, h = 64, split = 48;
  TwoSurfaces scene =
      two_surfaces(w, h, split, 50.0f, 5.0f, [](int x, int y) { return (x * 7 + y * 3) % 4 == 0; });
  for (int top = 4; top + 5 < h; top += 8)
    for (int y = top; y < top + 5; ++y)
      for (int x = split + 1; x < split + 6; ++x) {
        const bool border = y == top || y == top + 4 || x == split + 1 || x == split + 5;
        scene.contours.at(x, y) = border ? 255 : 0;
        scene.sparse.at(x, y) = kUnknown;
      }
  const DensifyInputs in = scene.inputs();
  for (const int iterations : {1, 2, 60}) {
    SCOPED_TRACE(iterations);
    DensifyParams params;
    params.solve_resolution = "full";
    params.max_iterations = iterations;
    Image<float> dense;
    Densifier(params).compute(in, dense);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        ASSERT_GE(dense.at(x, y), 5.0f) << x << "," << y;
        ASSERT_LE(dense.at(x, y), 50.0f) << x << "," << y;
      }
  }
}

TEST(Densifier, AutoResolutionHalvesOnlyWideFrames) {
  DensifyParams params;
  params.solve_resolution = "auto";
  const Densifier d(params);
  EXPECT_FALSE(d.solves_at_half(640));
  EXPECT_TRUE(d.solves_at_half(641));
  params.solve_resolution = "full";
  EXPECT_FALSE(Densifier(params).solves_at_half(1280));
  params.solve_resolution = "quarter";
  EXPECT_THROW(Densifier{params}, Error);
}

// Red-black Gauss-Seidel written out colour by colour and sweep by sweep.
void reference_gauss_seidel(const GridSystem& a, const Image<float>& b, Image<float>& x, int sweeps,
                            bool red_first) {
  const int w = a.width(), h = a.height();
  for (int s = 0; s < sweeps; ++s)
    for (int half = 0; half < 2; ++half) {
      const int colour = (half == 0) == red_first ? 0 : 1;
      for (int y = 0; y < h; ++y)
        for (int c = (y + colour) % 2; c < w; c += 2) {
          double v = b.at(c, y);
          if (c + 1 < w) v += a.wx.at(c, y) * x.at(c + 1, y);
          if (c > 0) v += a.wx.at(c - 1, y) * x.at(c - 1, y);
          if (y + 1 < h) v += a.wy.at(c, y) * x.at(c, y + 1);
          if (y > 0) v += a.wy.at(c, y - 1) * x.at(c, y - 1);
          x.at(c, y) = static_cast<float>(v / a.diag.at(c, y));
        }
    }
}

// The same sweeps out of the plain-layout row kernel, colour by colour and row by row: the float
// operations every layout of the rows must reproduce bit for bit.
void plain_layout_gauss_seidel(const GridSystem& a, const Image<float>& b, Image<float>& x,
                               int sweeps, bool red_first) {
  const int h = a.height();
  for (int s = 0; s < sweeps; ++s)
    for (int half = 0; half < 2; ++half) {
      const int colour = (half == 0) == red_first ? 0 : 1;
      for (int y = 0; y < h; ++y) {
        kernels::GridRow row = grid_row(a, y);
        if (y + 1 < h) row.x_below = x.row(y + 1);
        if (y > 0) row.x_above = x.row(y - 1);
        kernels::scalar::grid_smooth_row(row, (y + colour) % 2, b.row(y), x.row(y));
      }
    }
}

TEST(Multigrid, GaussSeidelMatchesThePlainColourOrder) {
  SweepRows rows;
  for (const auto& [w, h] :
       {std::pair{37, 23}, std::pair{2, 5}, std::pair{1, 1}, std::pair{8, 2}}) {
    const GridSystem a = random_system(w, h, 11);
    Image<float> b(w, h), x(w, h), expected(w, h), one_at_a_time(w, h);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int y = 0; y < h; ++y)
      for (int c = 0; c < w; ++c) b.at(c, y) = 10.0f * unit(rng), x.at(c, y) = unit(rng);
    for (const bool red_first : {true, false}) {
      expected = x;
      one_at_a_time = x;
      Image<float> fused = x;
      reference_gauss_seidel(a, b, expected, 3, red_first);
      Image<float> plain_layout = x;
      plain_layout_gauss_seidel(a, b, plain_layout, 3, red_first);
      gauss_seidel(a, b.cview(), fused.view(), 3, red_first, rows);
      for (int s = 0; s < 3; ++s)
        gauss_seidel(a, b.cview(), one_at_a_time.view(), 1, red_first, rows);
      for (int y = 0; y < h; ++y)
        for (int c = 0; c < w; ++c) {
          EXPECT_NEAR(fused.at(c, y), expected.at(c, y), 1e-4f * (1 + std::abs(expected.at(c, y))))
              << w << "x" << h << " " << c << "," << y;
          // Three sweeps in one pass over the rows give bit for bit the three separate sweeps,
          // and the rows split by column parity the plain layout's arithmetic.
          EXPECT_EQ(fused.at(c, y), one_at_a_time.at(c, y))
              << w << "x" << h << " " << c << "," << y;
          EXPECT_EQ(fused.at(c, y), plain_layout.at(c, y)) << w << "x" << h << " " << c << "," << y;
        }
    }
  }
}

TEST(Multigrid, SweepsWorkOutTheDiagonalOfASystemThatLeavesItOut) {
  // A system without its diagonal images (has_diagonal false, the images NaN) sweeps and
  // measures its residual to the bytes of the same system with them.
  for (const auto& [w, h] :
       {std::pair{37, 23}, std::pair{2, 5}, std::pair{1, 1}, std::pair{8, 2}}) {
    const GridSystem with = random_system(w, h, 13);
    ASSERT_TRUE(with.has_diagonal);
    GridSystem without = with;
    without.has_diagonal = false;
    without.diag.fill(std::numeric_limits<float>::quiet_NaN());
    without.inv_diag.fill(std::numeric_limits<float>::quiet_NaN());
    Image<float> b(w, h), x(w, h), coarse((w + 1) / 2, (h + 1) / 2);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    for (int y = 0; y < h; ++y)
      for (int c = 0; c < w; ++c) b.at(c, y) = 10.0f * unit(rng), x.at(c, y) = unit(rng);
    for (int y = 0; y < coarse.height(); ++y)
      for (int c = 0; c < coarse.width(); ++c) coarse.at(c, y) = unit(rng);
    SweepRows rows;
    Image<float> expected = x, actual = x;
    gauss_seidel(with, b.cview(), expected.view(), 3, true, rows);
    gauss_seidel(without, b.cview(), actual.view(), 3, true, rows);
    EXPECT_TRUE(testing::same_bytes(expected, actual)) << w << "x" << h;
    gauss_seidel_from_coarse(with, b.cview(), expected.view(), 2, false, rows, coarse.cview());
    gauss_seidel_from_coarse(without, b.cview(), actual.view(), 2, false, rows, coarse.cview());
    EXPECT_TRUE(testing::same_bytes(expected, actual)) << w << "x" << h;
    Image<float> r_with(w, h), r_without(w, h);
    const ResidualNorms n_with =
        gauss_seidel_residual(with, b.cview(), expected.view(), 1, true, r_with.view(), rows);
    const ResidualNorms n_without =
        gauss_seidel_residual(without, b.cview(), actual.view(), 1, true, r_without.view(), rows);
    EXPECT_TRUE(testing::same_bytes(r_with, r_without)) << w << "x" << h;
    EXPECT_EQ(n_with.relative(), n_without.relative()) << w << "x" << h;
  }
}

// A V-cycle from x = 0 out of the plain passes: smoothing, the whole residual, restriction,
// the coarse cycle, prolongation, smoothing.
void plain_cycle(const Multigrid& mg, const GridSystem& fine, int level, const Image<float>& b,
                 Image<float>& x) {
  const GridSystem& a = level == 0 ? fine : mg.coarse_system(level);
  SweepRows rows;
  x.fill(0.0f);
  if (level + 1 == mg.levels()) {
    gauss_seidel(a, b.cview(), x.view(), mg.coarsest_sweeps, true, rows);
    gauss_seidel(a, b.cview(), x.view(), mg.coarsest_sweeps, false, rows);
    return;
  }
  gauss_seidel(a, b.cview(), x.view(), mg.smoothing_sweeps, true, rows);
  Image<float> r(a.width(), a.height());
  residual(a, b.cview(), x.cview(), r.view());
  const GridSystem& coarse = mg.coarse_system(level + 1);
  Image<float> coarse_b(coarse.width(), coarse.height()), coarse_x(coarse.width(), coarse.height());
  restrict_sum(r.cview(), coarse_b.view());
  plain_cycle(mg, fine, level + 1, coarse_b, coarse_x);
  Image<float> correction(a.width(), a.height());
  prolong(coarse_x.cview(), correction.view());
  for (int y = 0; y < a.height(); ++y)
    for (int c = 0; c < a.width(); ++c) x.at(c, y) += correction.at(c, y);
  gauss_seidel(a, b.cview(), x.view(), mg.smoothing_sweeps, false, rows);
}

Image<float> random_vector(int w, int h, unsigned seed, float scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  Image<float> v(w, h);
  for (int y = 0; y < h; ++y)
    for (int c = 0; c < w; ++c) v.at(c, y) = scale * unit(rng);
  return v;
}

// Whether two images hold the same floats bit for bit; names the first pixel that differs.
::testing::AssertionResult same_pixels(const Image<float>& actual, const Image<float>& expected) {
  if (actual.width() != expected.width() || actual.height() != expected.height())
    return ::testing::AssertionFailure() << "sizes differ";
  for (int y = 0; y < expected.height(); ++y)
    for (int c = 0; c < expected.width(); ++c)
      if (actual.at(c, y) != expected.at(c, y))
        return ::testing::AssertionFailure() << "pixel " << c << "," << y << ": " << actual.at(c, y)
                                             << " vs " << expected.at(c, y);
  return ::testing::AssertionSuccess();
}

TEST(Multigrid, CycleIsThePlainPassesBitForBit) {
  // Several levels, odd sizes, one level only, and a single row. One hierarchy is rebuilt for
  // each system, as the densifier does every frame: nothing of the last system may linger.
  Multigrid mg;
  for (const auto& [w, h] : {std::pair{97, 61}, std::pair{50, 31}, std::pair{20, 9},
                             std::pair{33, 1}, std::pair{97, 61}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    const GridSystem a = random_system(w, h, static_cast<unsigned>(5 + w + h));
    mg.build(a);
    const Image<float> r = random_vector(w, h, 9, 10.0f);
    Image<float> expected(w, h), z(w, h), z_dot(w, h);
    plain_cycle(mg, a, 0, r, expected);
    // Stale values in z must not matter: the cycle starts from 0.
    z = random_vector(w, h, 4, 100.0f);
    z_dot = z;
    mg.cycle(r.cview(), z.view());
    const double rz = mg.cycle_dot(r.cview(), z_dot.view());
    EXPECT_EQ(rz, dot(r.cview(), expected.cview()));
    ASSERT_TRUE(same_pixels(z, expected));
    ASSERT_TRUE(same_pixels(z_dot, expected));
  }
}

TEST(GridSystem, FusedResidualPassesAreThePlainOnesBitForBit) {
  const int w = 45, h = 17;
  const GridSystem a = random_system(w, h, 8);
  const Image<float> b = random_vector(w, h, 1, 10.0f), x0 = random_vector(w, h, 2, 30.0f);
  const Image<float> dir = random_vector(w, h, 3, 1.0f);
  Image<float> r(w, h), fused_r(w, h);
  residual(a, b.cview(), x0.cview(), r.view());
  EXPECT_EQ(residual_dot(a, b.cview(), x0.cview(), fused_r.view()), dot(r.cview(), r.cview()));
  ASSERT_TRUE(same_pixels(fused_r, r));

  const float alpha = 0.37f;
  Image<float> x = x0, fused_x = x0;
  for (int y = 0; y < h; ++y)
    for (int c = 0; c < w; ++c) x.at(c, y) += alpha * dir.at(c, y);
  residual(a, b.cview(), x.cview(), r.view());
  const double rr =
      step_residual_dot(a, b.cview(), alpha, dir.cview(), fused_x.view(), fused_r.view());
  EXPECT_EQ(rr, dot(r.cview(), r.cview()));
  ASSERT_TRUE(same_pixels(fused_x, x));
  ASSERT_TRUE(same_pixels(fused_r, r));
}

TEST(Multigrid, StartSweepsAndResidualInOnePassAreThePlainPassesBitForBit) {
  SweepRows rows;
  for (const auto& [w, h] : {std::pair{45, 17}, std::pair{8, 1}, std::pair{3, 2}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    const GridSystem a = random_system(w, h, 6);
    const Image<float> b = random_vector(w, h, 1, 10.0f);
    const Image<float> coarse = random_vector((w + 1) / 2, (h + 1) / 2, 2, 30.0f);
    for (const int sweeps : {0, 1, 4}) {
      Image<float> x(w, h), r(w, h);
      prolong(coarse.cview(), x.view());
      gauss_seidel(a, b.cview(), x.view(), sweeps, true, rows);
      residual(a, b.cview(), x.cview(), r.view());
      // Stale values in x must not matter: the pass starts from the prolonged coarse values.
      Image<float> fused_x = random_vector(w, h, 7, 100.0f), fused_r(w, h);
      const ResidualNorms n = gauss_seidel_residual(a, b.cview(), fused_x.view(), sweeps, true,
                                                    fused_r.view(), rows, coarse.cview());
      EXPECT_EQ(n.rr, dot(r.cview(), r.cview()));
      EXPECT_EQ(n.bb, dot(b.cview(), b.cview()));
      ASSERT_TRUE(same_pixels(fused_x, x)) << sweeps << " sweeps";
      ASSERT_TRUE(same_pixels(fused_r, r)) << sweeps << " sweeps";
      // Without an image for r, the same norms and the same x.
      Image<float> norms_x = random_vector(w, h, 8, 100.0f);
      SweepRows fresh;  // its spare row sized by this pass alone
      const ResidualNorms m = gauss_seidel_residual(a, b.cview(), norms_x.view(), sweeps, true, {},
                                                    fresh, coarse.cview());
      EXPECT_EQ(m.rr, n.rr) << sweeps << " sweeps";
      EXPECT_EQ(m.bb, n.bb) << sweeps << " sweeps";
      ASSERT_TRUE(same_pixels(norms_x, x)) << sweeps << " sweeps";
      // Without a coarse start the pass sweeps the x it is given.
      Image<float> given = x, swept = x;
      gauss_seidel(a, b.cview(), swept.view(), sweeps, true, rows);
      gauss_seidel_residual(a, b.cview(), given.view(), sweeps, true, fused_r.view(), rows);
      ASSERT_TRUE(same_pixels(given, swept)) << sweeps << " sweeps";
    }
  }
}

TEST(ConjugateGradients, AfterSweepsIsTheSweepsThenTheSolveBitForBit) {
  SweepRows rows;
  const int w = 61, h = 29;
  const GridSystem a = random_system(w, h, 12);
  const Image<float> b = random_vector(w, h, 3, 10.0f);
  const Image<float> coarse = random_vector((w + 1) / 2, (h + 1) / 2, 4, 5.0f);
  for (const int iterations : {1, 3}) {
    Multigrid mg, fused_mg;
    mg.build(a);
    fused_mg.build(a);
    CgScratch scratch, fused_scratch;
    Image<float> x(w, h);
    prolong(coarse.cview(), x.view());
    gauss_seidel(a, b.cview(), x.view(), 4, true, rows);
    const SolverReport plain = solve_pcg(a, b.cview(), x.view(), &mg, iterations, 1e-9, scratch);
    Image<float> fused_x(w, h);
    const SolverReport fused =
        solve_pcg_after_sweeps(a, b.cview(), coarse.cview(), fused_x.view(), 4, &fused_mg,
                               iterations, 1e-9, fused_scratch);
    EXPECT_EQ(fused.iterations, iterations);
    EXPECT_EQ(fused.iterations, plain.iterations);
    EXPECT_EQ(fused.initial_residual, plain.initial_residual);
    EXPECT_EQ(fused.final_residual, plain.final_residual);
    // PCG lowers the error's energy norm each iteration, not always the residual's 2-norm.
    if (iterations > 1) {
      EXPECT_LT(fused.final_residual, fused.initial_residual);
    }
    ASSERT_TRUE(same_pixels(fused_x, x)) << iterations << " iterations";
  }
}

TEST(Multigrid, TransfersOnOddSizes) {
  Image<float> fine(5, 3), coarse(3, 2), back(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) fine.at(x, y) = static_cast<float>(10 * y + x);
  restrict_sum(fine.cview(), coarse.view());
  EXPECT_FLOAT_EQ(coarse.at(0, 0), 0 + 1 + 10 + 11);
  EXPECT_FLOAT_EQ(coarse.at(2, 0), 4 + 14);
  EXPECT_FLOAT_EQ(coarse.at(2, 1), 24);
  restrict_mean(fine.cview(), coarse.view());
  EXPECT_FLOAT_EQ(coarse.at(0, 0), 5.5f);
  EXPECT_FLOAT_EQ(coarse.at(2, 0), 9.0f);
  EXPECT_FLOAT_EQ(coarse.at(1, 1), 22.5f);
  prolong(coarse.cview(), back.view());
  EXPECT_FLOAT_EQ(back.at(1, 1), 5.5f);
  EXPECT_FLOAT_EQ(back.at(4, 2), 24.0f);
}

// A system whose data terms and edges are drawn from [0.1, 2) in row order (data, then the edge
// to the right, then the edge below; none past the last column or row).
GridSystem uniform_random_system(int w, int h, std::mt19937& rng) {
  GridSystem a;
  a.resize(w, h);
  std::uniform_real_distribution<float> u(0.1f, 2.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      a.data.at(x, y) = u(rng);
      a.wx.at(x, y) = x + 1 < w ? u(rng) : 0.0f;
      a.wy.at(x, y) = y + 1 < h ? u(rng) : 0.0f;
    }
  a.update_diagonal();
  return a;
}

TEST(Multigrid, CoarseOutputsOverwriteWhatTheirImagesHeld) {
  // The coarse system and the restrictions write every coarse value (no fill first): into images
  // that hold NaN they give the bytes they give into fresh ones, on even and odd sizes.
  for (const auto& [w, h] : {std::pair{9, 7}, std::pair{8, 6}, std::pair{5, 2}, std::pair{1, 1}}) {
    std::mt19937 rng(21);
    const GridSystem a = uniform_random_system(w, h, rng);
    GridSystem fresh, stale;
    coarsen(a, fresh);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    stale.resize(fresh.width(), fresh.height());
    for (Image<float>* img : {&stale.data, &stale.wx, &stale.wy, &stale.diag, &stale.inv_diag})
      img->fill(nan);
    coarsen(a, stale);
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
    EXPECT_TRUE(testing::same_bytes(stale.data.cview(), fresh.data.cview()));
    EXPECT_TRUE(testing::same_bytes(stale.wx.cview(), fresh.wx.cview()));
    EXPECT_TRUE(testing::same_bytes(stale.wy.cview(), fresh.wy.cview()));
    EXPECT_TRUE(testing::same_bytes(stale.diag.cview(), fresh.diag.cview()));
    Image<float> sum(fresh.width(), fresh.height()), stale_sum(fresh.width(), fresh.height());
    sum.fill(0.0f);
    stale_sum.fill(nan);
    restrict_sum(a.data.cview(), sum.view());
    restrict_sum(a.data.cview(), stale_sum.view());
    EXPECT_TRUE(testing::same_bytes(stale_sum.cview(), sum.cview()));
    // No coarse edge leaves the last column to the right, nor the last row downwards.
    for (int y = 0; y < fresh.height(); ++y) EXPECT_EQ(stale.wx.at(fresh.width() - 1, y), 0.0f);
    for (int x = 0; x < fresh.width(); ++x) EXPECT_EQ(stale.wy.at(x, fresh.height() - 1), 0.0f);
  }
}

TEST(Densifier, DiagonalContourStillSeparates) {
  Image<std::uint8_t> diagonal(4, 4), closed(4, 4);
  diagonal.fill(0);
  for (int i = 0; i < 4; ++i) diagonal.at(i, i) = 255;
  close_diagonal_gaps(diagonal.cview(), closed.view());
  // Every 2x2 block that touched only at a corner now shares an edge.
  for (int i = 0; i + 1 < 4; ++i) EXPECT_TRUE(closed.at(i + 1, i) || closed.at(i, i + 1));
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(closed.at(i, i));
}

// The rule as a scan: every 2x2 block in row-major order, filling in place.
Image<std::uint8_t> close_gaps_by_scan(const Image<std::uint8_t>& contours) {
  const int w = contours.width(), h = contours.height();
  Image<std::uint8_t> closed(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) closed.at(x, y) = contours.at(x, y) ? 1 : 0;
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const bool a = closed.at(x, y), b = closed.at(x + 1, y);
      const bool c = closed.at(x, y + 1), d = closed.at(x + 1, y + 1);
      if (a && d && !b && !c)
        closed.at(x + 1, y) = 1;
      else if (b && c && !a && !d)
        closed.at(x, y) = 1;
    }
  return closed;
}

TEST(Densifier, DiagonalGapsCloseAsTheBlockByBlockScanDoes) {
  std::mt19937 rng(17);
  for (const int w : {1, 2, 3, 17, 64}) {
    for (const int h : {1, 2, 9}) {
      for (const int density : {5, 30, 60}) {
        Image<std::uint8_t> contours(w, h), closed(w, h);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            contours.at(x, y) = static_cast<int>(rng() % 100) < density ? 255 : 0;
        close_diagonal_gaps(contours.cview(), closed.view());
        const Image<std::uint8_t> expected = close_gaps_by_scan(contours);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            ASSERT_EQ(closed.at(x, y), expected.at(x, y))
                << w << "x" << h << " density " << density << " at " << x << "," << y;
      }
    }
  }
}

TEST(Densifier, WarmStartConvergesFaster) {
  const Problem p = random_problem(160, 120, 6, 0.1);
  DensifyParams params;
  params.tolerance = 1e-5;
  params.max_iterations = 1000;
  Densifier d(params);
  Image<float> dense;
  d.compute(inputs_of(p), dense);
  const int cold = d.last_report().iterations;
  d.compute(inputs_of(p), dense);  // same frame again: starts at its own solution
  EXPECT_LT(d.last_report().iterations, cold);
  EXPECT_LE(d.last_report().initial_residual, 1e-5);
}

// With no previous frame the solve starts from each pixel's hint (its sparse value, or the value
// its row's hole is filled towards), not from the sparse values with zeros in the holes: on a
// slanted surface sampled at a few pixels, the first residual is several times smaller.
TEST(Densifier, ColdStartBeginsAtTheHoleHints) {
  const int w = 120, h = 90;
  Image<float> sparse(w, h);
  std::mt19937 rng(8);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      sparse.at(x, y) = rng() % 10 == 0 ? 20.0f + 0.1f * x + 0.05f * y : kUnknown;
  Densifier d(DensifyParams{});
  DensifyInputs in;
  in.sparse = sparse.cview();
  Image<float> dense;
  d.compute(in, dense);
  ASSERT_TRUE(d.last_report().converged);
  // The residual of the old start, sparse values and zeros, for the same system.
  Image<float> zero_start(w, h), r(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      zero_start.at(x, y) = std::isfinite(sparse.at(x, y)) ? sparse.at(x, y) : 0.0f;
  residual(d.last_system(), d.last_rhs(), zero_start.cview(), r.view());
  const double zero_start_residual =
      std::sqrt(dot(r.cview(), r.cview()) / dot(d.last_rhs(), d.last_rhs()));
  EXPECT_LT(d.last_report().initial_residual * 5, zero_start_residual);
}

TEST(Densifier, EmptySparseMapStillGivesAFiniteMap) {
  Image<float> sparse(32, 24);
  sparse.fill(kUnknown);
  Densifier d(DensifyParams{});
  DensifyInputs in;
  in.sparse = sparse.cview();
  Image<float> dense;
  d.compute(in, dense);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) ASSERT_TRUE(std::isfinite(dense.at(x, y)));
}

// A surface slanting towards the camera runs into the left border, where the right image holds
// no match: its 40 border columns are holes.
TEST(Densifier, HolesAtTheLeftBorderContinueTheSlantOfTheSurfaceBesideThem) {
  const int w = 160, h = 48, border = 40;
  const auto truth = [](int x, int y) { return 40.0f - 0.25f * x + 0.02f * y; };
  Image<float> sparse(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) sparse.at(x, y) = x < border ? kUnknown : truth(x, y);
  const auto border_error = [&](double rms, const Image<float>& map) {
    DensifyParams params;
    params.border_plane_rms = rms;
    Densifier d(params);
    DensifyInputs in;
    in.sparse = map.cview();
    Image<float> dense;
    d.compute(in, dense);
    double worst = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < border; ++x)
        worst = std::max(worst, std::abs(double(dense.at(x, y)) - truth(x, y)));
    return std::make_pair(worst, dense);
  };
  const auto [flat, flat_map] = border_error(0, sparse);
  const auto [planar, planar_map] = border_error(DensifyParams{}.border_plane_rms, sparse);
  EXPECT_GT(flat, 5.0);  // the first match of the row, 10 px of disparity short at the border
  EXPECT_LT(planar, flat / 2);

  // Two surfaces within the fitted columns fit no plane: the border keeps the row's first match,
  // bit for bit.
  Image<float> two = sparse;
  for (int y = 0; y < h; ++y)
    for (int x = border + 16; x < w; ++x) two.at(x, y) = truth(x, y) - 8.0f;
  const auto [two_off, two_off_map] = border_error(0, two);
  const auto [two_on, two_on_map] = border_error(DensifyParams{}.border_plane_rms, two);
  EXPECT_EQ(two_off, two_on);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ASSERT_EQ(two_off_map.at(x, y), two_on_map.at(x, y));
}

TEST(Densifier, RejectsMismatchedInputsAndBadParams) {
  Image<float> sparse(32, 24), other(31, 24);
  sparse.fill(1.0f);
  Densifier d(DensifyParams{});
  DensifyInputs in;
  in.sparse = sparse.cview();
  in.m_intensity = other.cview();
  Image<float> dense;
  EXPECT_THROW(d.compute(in, dense), Error);
  DensifyParams bad;
  bad.lambda_d = 0;
  EXPECT_THROW(Densifier{bad}, Error);
  bad = DensifyParams{};
  bad.tolerance = 0;
  EXPECT_THROW(Densifier{bad}, Error);
  bad = DensifyParams{};
  bad.border_plane_rms = -1;
  EXPECT_THROW(Densifier{bad}, Error);
  for (int size : {1, 4, 7}) {
    bad = DensifyParams{};
    bad.median_size = size;
    EXPECT_THROW(Densifier{bad}, Error) << size;
  }
  for (int threads : {-1, 17}) {
    bad = DensifyParams{};
    bad.row_threads = threads;
    EXPECT_THROW(Densifier{bad}, Error) << threads;
  }
}

TEST(Multigrid, CoarseningPreservesTheEnergyOfPiecewiseConstantVectors) {
  // x^T A x = y^T A_c y when x is y repeated over 2x2 blocks (Galerkin with P = injection).
  const int w = 9, h = 7;
  std::mt19937 rng(7);
  const GridSystem a = uniform_random_system(w, h, rng);
  std::uniform_real_distribution<float> u(0.1f, 2.0f);
  GridSystem c;
  coarsen(a, c);
  ASSERT_EQ(c.width(), 5);
  ASSERT_EQ(c.height(), 4);
  Image<float> yc(5, 4), x(w, h), ax(w, h), ayc(5, 4);
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) yc.at(i, j) = u(rng);
  for (int yy = 0; yy < h; ++yy)
    for (int xx = 0; xx < w; ++xx) x.at(xx, yy) = yc.at(xx / 2, yy / 2);
  apply(a, x.cview(), ax.view());
  apply(c, yc.cview(), ayc.view());
  EXPECT_NEAR(dot(x.cview(), ax.cview()), dot(yc.cview(), ayc.cview()), 1e-3);
}

TEST(Multigrid, HalfSizeEdgeScaleKeepsTheEnergyOfARamp) {
  // Uniform edges, no data term: x^T A x is the membrane energy. A ramp of slope 1 at full size
  // is, aggregated, a ramp of slope 2 at half size; with the plain Galerkin edges its energy
  // doubles, with kHalfSizeEdgeScale it is the full-size energy but for the one fine step that
  // lies inside the last aggregate of each row.
  const int w = 32, h = 16;
  GridSystem a;
  a.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      a.data.at(x, y) = 0.0f;
      a.wx.at(x, y) = x + 1 < w ? 1.5f : 0.0f;
      a.wy.at(x, y) = y + 1 < h ? 1.5f : 0.0f;
    }
  a.update_diagonal();
  Image<float> ramp(w, h), a_ramp(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ramp.at(x, y) = static_cast<float>(x);
  apply(a, ramp.cview(), a_ramp.view());
  const double fine_energy = dot(ramp.cview(), a_ramp.cview());
  EXPECT_DOUBLE_EQ(fine_energy, 1.5 * (w - 1) * h);

  Image<float> coarse_ramp(w / 2, h / 2), a_coarse(w / 2, h / 2);
  restrict_mean(ramp.cview(), coarse_ramp.view());
  const auto coarse_energy = [&](float edge_scale) {
    GridSystem c;
    coarsen(a, c, edge_scale);
    apply(c, coarse_ramp.cview(), a_coarse.view());
    return dot(coarse_ramp.cview(), a_coarse.cview());
  };
  EXPECT_DOUBLE_EQ(coarse_energy(1.0f), 2.0 * 1.5 * (w - 2) * h);
  EXPECT_DOUBLE_EQ(coarse_energy(kHalfSizeEdgeScale), 1.5 * (w - 2) * h);
}

// The half-size solve takes its system from the full-size multigrid's level 1 with the edges
// scaled: that must be the scaled coarsening itself, bit for bit, odd sizes included.
TEST(Multigrid, ScaledLevelOneIsTheScaledCoarsening) {
  for (const auto& [w, h] : {std::pair{9, 7}, std::pair{64, 30}}) {
    GridSystem a;
    a.resize(w, h);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 2.0f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        a.data.at(x, y) = u(rng) * 1e-3f;
        a.wx.at(x, y) = x + 1 < w ? u(rng) : 0.0f;
        a.wy.at(x, y) = y + 1 < h ? u(rng) : 0.0f;
      }
    a.update_diagonal();
    Multigrid mg;
    mg.build(a, 4);
    ASSERT_GT(mg.levels(), 1);
    GridSystem expected, scaled;
    coarsen(a, expected, kHalfSizeEdgeScale);
    scale_edges(mg.coarse_system(1), scaled, kHalfSizeEdgeScale);
    ASSERT_EQ(scaled.width(), expected.width());
    ASSERT_EQ(scaled.height(), expected.height());
    for (int y = 0; y < expected.height(); ++y)
      for (int x = 0; x < expected.width(); ++x) {
        ASSERT_EQ(scaled.data.at(x, y), expected.data.at(x, y));
        ASSERT_EQ(scaled.wx.at(x, y), expected.wx.at(x, y));
        ASSERT_EQ(scaled.wy.at(x, y), expected.wy.at(x, y));
        ASSERT_EQ(scaled.diag.at(x, y), expected.diag.at(x, y));
        ASSERT_EQ(scaled.inv_diag.at(x, y), expected.inv_diag.at(x, y));
      }
  }
}

}  // namespace
}  // namespace dco::densify
