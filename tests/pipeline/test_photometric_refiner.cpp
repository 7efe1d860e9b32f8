#include "dco/pipeline/densify/photometric_refiner.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/kernels/photometric_kernels.hpp"
#include "dco/pipeline/row_team.hpp"

namespace dco::densify {
namespace {

// A smooth texture with detail in every direction.
float texture(double x, double y) {
  return static_cast<float>(128 + 45 * std::sin(0.37 * x + 0.11 * y) +
                            35 * std::sin(0.23 * y - 0.19 * x) +
                            20 * std::sin(0.71 * x + 0.53 * y));
}

std::uint8_t grey(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0f, 255.0f)));
}

// A rectified pair whose true disparity is disparity(x, y): the right image at x - d shows what
// the left shows at x.
template <class Disparity>
void render_pair(int w, int h, const Disparity& disparity, Image<std::uint8_t>& left,
                 Image<std::uint8_t>& right) {
  left.resize(w, h);
  right.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      left.view().row(y)[x] = grey(texture(x, y));
      // The right pixel u sees the left's x with x - disparity(x) = u: solved by a few fixed-point
      // steps (the disparities here vary slowly or are constant per region).
      double from = x;
      for (int k = 0; k < 8; ++k) from = x + disparity(from, y);
      right.view().row(y)[x] = grey(texture(from, y));
    }
}

Image<float> filled(int w, int h, float value) {
  Image<float> d(w, h);
  for (int y = 0; y < h; ++y) std::fill(d.view().row(y), d.view().row(y) + w, value);
  return d;
}

double median_abs_error(const Image<float>& d, float truth, int margin) {
  std::vector<double> e;
  for (int y = margin; y < d.height() - margin; ++y)
    for (int x = margin; x < d.width() - margin; ++x)
      e.push_back(std::abs(d.cview().row(y)[x] - truth));
  std::nth_element(e.begin(), e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2), e.end());
  return e[e.size() / 2];
}

// The solver's maps are smooth and off by a few tenths of a pixel where matches are few or
// imprecise: such a start, on a constant disparity.
TEST(PhotometricRefiner, FindsASubPixelDisparityFromASmoothStartOffByTenths) {
  Image<std::uint8_t> left, right;
  render_pair(
      96, 64, [](double, double) { return 6.3; }, left, right);
  for (const float amplitude : {0.3f, 0.45f}) {
    Image<float> d(96, 64);
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 96; ++x)
        d.view().row(y)[x] = 6.3f + amplitude * std::sin(0.11f * x + 0.07f * y + 0.4f);
    SCOPED_TRACE(amplitude);
    const double before = median_abs_error(d, 6.3f, 12);
    EXPECT_GT(before, 0.15);
    PhotometricRefiner refiner;
    refiner.refine(left.cview(), right.cview(), PhotometricParams{}, d.view());
    EXPECT_LT(median_abs_error(d, 6.3f, 12), 0.3 * before);
  }
}

TEST(PhotometricRefiner, DefaultsMoveASlantedSurfaceTowardsTheTruthAndKeepItsStep) {
  // A slanted background (4 .. 10 px across the width) and a nearer square at 16 px.
  const int w = 128, h = 80;
  const auto truth = [](double x, double y) {
    const bool square = x >= 48 && x < 88 && y >= 20 && y < 60;
    return square ? 16.0 : 4.0 + 6.0 * x / 128.0;
  };
  Image<std::uint8_t> left, right;
  render_pair(w, h, truth, left, right);
  // The start: the truth off by a smooth few tenths of a pixel, the square's step in place.
  Image<float> d(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      d.view().row(y)[x] = static_cast<float>(truth(x, y) + 0.35 * std::sin(0.13 * x + 0.09 * y));
  int band = 0;
  const auto errors = [&](const Image<float>& map, double& mean_on_slope, int& wrong_near_step) {
    double sum = 0;
    int n = 0;
    wrong_near_step = 0;
    band = 0;
    for (int y = 2; y < h - 2; ++y)
      for (int x = 20; x < w - 2; ++x) {
        const double e = std::abs(map.cview().row(y)[x] - truth(x, y));
        const bool near_step =
            std::abs(x - 48) <= 3 || std::abs(x - 88) <= 3 ||
            ((std::abs(y - 20) <= 3 || std::abs(y - 60) <= 3) && x >= 45 && x < 91);
        if (near_step) {
          wrong_near_step += e > 1.0;
          band += 1;
        } else if (!(x >= 48 && x < 88 && y >= 20 && y < 60)) {
          sum += e, ++n;
        }
      }
    mean_on_slope = sum / n;
  };
  double before_slope = 0, after_slope = 0;
  int before_step = 0, after_step = 0;
  errors(d, before_slope, before_step);
  PhotometricRefiner refiner;
  refiner.refine(left.cview(), right.cview(), PhotometricParams{}, d.view());
  errors(d, after_slope, after_step);
  EXPECT_GT(before_slope, 0.2);
  EXPECT_LT(after_slope, 0.6 * before_slope);
  // The outline stays: within 3 px of it, at most 5 % of the pixels more than 1 px off (the strip
  // left of the square that the right camera cannot see has no true match to move towards).
  EXPECT_LE(after_step, before_step + band / 20) << before_step << " of " << band;
}

// The plain order the fused pass must reproduce: every row's terms, then the couplings, then
// each half-sweep over the whole image; the scalar kernels throughout; the clamp at 0 last.
// Returns how many values the clamp raised.
int refine_plainly(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                   const PhotometricParams& params, ImageView<float> d) {
  const int w = d.width, h = d.height;
  Image<float> a(w, h), rhs(w, h), s(w, h), wx(w, h), wy(w, h), inv(w, h), deriv(w, 12);
  const auto rows_of = [&](int first) {
    return kernels::DerivativeRows{deriv.view().row(first),     deriv.view().row(first + 1),
                                   deriv.view().row(first + 2), deriv.view().row(first + 3),
                                   deriv.view().row(first + 4), deriv.view().row(first + 5)};
  };
  const auto derive = [&](ImageView<const std::uint8_t> img, int y, int first) {
    const std::uint8_t* r[5];
    for (int k = 0; k < 5; ++k) r[k] = img.row(std::clamp(y + k - 2, 0, h - 1));
    kernels::scalar::derivative_row(r, w, rows_of(first));
  };
  const kernels::pixel::PhotometricWeights weights{static_cast<float>(params.alpha),
                                                   static_cast<float>(params.delta),
                                                   static_cast<float>(params.gamma)};
  for (int it = 0; it < params.iterations; ++it) {
    for (int y = 0; y < h; ++y) {
      derive(left, y, 0);
      derive(right, y, 6);
      kernels::PhotometricTermRows t{};
      for (int k = 0; k < 6; ++k)
        t.left[k] = deriv.view().row(k), t.right[k] = deriv.view().row(6 + k);
      t.d = d.row(y), t.d_up = d.row(std::max(y - 1, 0)), t.d_down = d.row(std::min(y + 1, h - 1));
      t.width = w;
      kernels::scalar::photometric_terms_row(t, weights, a.view().row(y), rhs.view().row(y),
                                             s.view().row(y));
    }
    for (int y = 0; y < h; ++y)
      kernels::scalar::photometric_couplings_row(
          {a.view().row(y), s.view().row(y), y + 1 < h ? s.view().row(y + 1) : nullptr,
           y > 0 ? wy.view().row(y - 1) : nullptr, w},
          wx.view().row(y), wy.view().row(y), inv.view().row(y));
    for (int half = 0; half < 2 * params.sweeps; ++half)
      for (int y = 0; y < h; ++y) {
        const kernels::SorRow row{rhs.view().row(y),
                                  inv.view().row(y),
                                  wx.view().row(y),
                                  wy.view().row(y),
                                  y > 0 ? wy.view().row(y - 1) : nullptr,
                                  y > 0 ? d.row(y - 1) : nullptr,
                                  y + 1 < h ? d.row(y + 1) : nullptr,
                                  w};
        kernels::scalar::sor_row(row, (y + half) & 1, kPhotometricOmega, d.row(y));
      }
  }
  int raised = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      raised += d.row(y)[x] < 0.0f;
      d.row(y)[x] = std::max(d.row(y)[x], 0.0f);
    }
  return raised;
}

// A pair and a start map for the order tests: a surface with a step, or one that starts at
// disparity 0, where the sweeps go below 0 and the clamp must come after all of them; the start
// is the truth rounded, a third of it 0.4 px lower.
struct OrderCase {
  Image<std::uint8_t> left, right;
  Image<float> start;
};
OrderCase order_case(int w, int h, bool from_zero) {
  const auto truth = [from_zero](double x, double y) {
    return from_zero ? 0.02 * x : 3.0 + 0.05 * x + ((x > 30 && y > 12) ? 5 : 0);
  };
  OrderCase c;
  render_pair(w, h, truth, c.left, c.right);
  c.start.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      c.start.view().row(y)[x] =
          static_cast<float>(std::round(truth(x, y))) - 0.4f * ((x + y) % 3 == 0);
  return c;
}

TEST(PhotometricRefiner, OnePassOverTheRowsGivesThePlainOrdersBits) {
  int raised_from_zero = 0;
  for (const bool zero : {false, true})
    for (const int w : {1, 2, 7, 33, 70})
      for (const int h : {1, 3, 9, 25}) {
        const OrderCase c = order_case(w, h, zero);
        for (const int sweeps : {1, 3}) {
          PhotometricParams params;
          params.sweeps = sweeps;
          params.iterations = 2;
          Image<float> fused(w, h), plain(w, h);
          fused.copy_from(c.start.cview());
          plain.copy_from(c.start.cview());
          PhotometricRefiner refiner;
          refiner.refine(c.left.cview(), c.right.cview(), params, fused.view());
          const int raised = refine_plainly(c.left.cview(), c.right.cview(), params, plain.view());
          if (zero) raised_from_zero += raised;
          for (int y = 0; y < h; ++y)
            ASSERT_EQ(std::memcmp(fused.cview().row(y), plain.cview().row(y), sizeof(float) * w), 0)
                << (zero ? "from zero " : "stepped ") << w << "x" << h << " sweeps " << sweeps
                << " row " << y;
        }
      }
  EXPECT_GT(raised_from_zero, 0);
}

// With a row team of several threads the passes of the plain order are shared out by rows: the
// single pass's bits on every thread count, on maps that step and that go below 0, with blocks
// of one row and fewer rows than threads, one refiner going from size to size.
TEST(PhotometricRefiner, RowTeamsGiveTheBitsOfTheSinglePass) {
  for (const int threads : {2, 3, 4}) {
    pipeline::RowTeam team(threads);
    PhotometricRefiner shared(&team), single;
    for (const auto& [w, h] :
         {std::pair{70, 25}, std::pair{33, 3}, std::pair{7, 1}, std::pair{64, 9}}) {
      for (const bool zero : {false, true}) {
        const OrderCase c = order_case(w, h, zero);
        for (const int sweeps : {1, 3}) {
          PhotometricParams params;
          params.sweeps = sweeps;
          Image<float> expected(w, h), actual(w, h);
          expected.copy_from(c.start.cview());
          actual.copy_from(c.start.cview());
          single.refine(c.left.cview(), c.right.cview(), params, expected.view());
          shared.refine(c.left.cview(), c.right.cview(), params, actual.view());
          for (int y = 0; y < h; ++y)
            ASSERT_EQ(
                std::memcmp(expected.cview().row(y), actual.cview().row(y), sizeof(float) * w), 0)
                << threads << " threads, " << w << "x" << h << (zero ? " from zero" : " stepped")
                << ", sweeps " << sweeps << ", row " << y;
        }
      }
    }
  }
}

TEST(PhotometricRefiner, RefusesImagesOfAnotherSizeOrColourAndLeavesTheMapWithoutIterations) {
  Image<std::uint8_t> left, right;
  render_pair(
      40, 20, [](double, double) { return 3.0; }, left, right);
  Image<float> d = filled(40, 20, 3.0f);
  PhotometricRefiner refiner;
  Image<std::uint8_t> small(39, 20), colour(40, 20, 3);
  for (const auto& [l, r] :
       {std::pair{left.cview(), small.cview()}, std::pair{small.cview(), right.cview()},
        std::pair{colour.cview(), right.cview()}}) {
    try {
      refiner.refine(l, r, PhotometricParams{}, d.view());
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr("photometric refinement"));
      EXPECT_THAT(e.what(), ::testing::HasSubstr("40x20"));
    }
  }
  // No iterations: the map as it was, bit for bit, negative values included.
  d.view().row(3)[5] = -2.0f;
  Image<float> before(40, 20);
  before.copy_from(d.cview());
  PhotometricParams none;
  none.iterations = 0;
  refiner.refine(left.cview(), right.cview(), none, d.view());
  for (int y = 0; y < 20; ++y)
    EXPECT_EQ(std::memcmp(d.cview().row(y), before.cview().row(y), sizeof(float) * 40), 0);
  // With them, nothing ends below 0.
  refiner.refine(left.cview(), right.cview(), PhotometricParams{}, d.view());
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 40; ++x) EXPECT_GE(d.cview().row(y)[x], 0.0f);
}

TEST(PhotometricRefiner, RefinesFramesUpToTheirPixelBudget) {
  PhotometricParams p;
  EXPECT_TRUE(refines(p, 960, 540));    // 518,400 pixels: FlyingThings3D, the Karlsruhe clip's size
  EXPECT_FALSE(refines(p, 1280, 720));  // 921,600: the headset camera at full size
  p.max_pixels = 1280 * 720;
  EXPECT_TRUE(refines(p, 1280, 720));
  p.max_pixels = 0;
  EXPECT_FALSE(refines(p, 1, 1));
  p.max_pixels = 600000;
  p.iterations = 0;
  EXPECT_FALSE(refines(p, 64, 48));
}

}  // namespace
}  // namespace dco::densify
