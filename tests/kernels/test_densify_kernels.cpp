#include "dco/kernels/densify_kernels.hpp"
#include "for_each_target.hpp"
#include "kernel_test_rows.hpp"
#include "occlusion_reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

namespace dco::kernels {
namespace {

// Widths around the lane counts of every target (4 .. 16 float lanes, SVE up to 64), odd ones,
// and the one- and two-column rows that have no interior.
const std::vector<int> kWidths = {1, 2, 3, 5, 8, 15, 16, 17, 18, 31, 33, 64, 65, 66, 130, 257};

// A row of a diagonally dominant system, with or without the rows above and below.
struct RowData {
  std::vector<float> diag, inv, wx, wy, wy_above, x_above, x_below, b, x;

  RowData(std::mt19937& rng, int w) {
    wx = random_floats(rng, w, 0.0f, 2.0f);
    wy = random_floats(rng, w, 0.0f, 2.0f);
    wy_above = random_floats(rng, w, 0.0f, 2.0f);
    x_above = random_floats(rng, w, -50.0f, 50.0f);
    x_below = random_floats(rng, w, -50.0f, 50.0f);
    b = random_floats(rng, w, -10.0f, 10.0f);
    x = random_floats(rng, w, -50.0f, 50.0f);
    diag = random_floats(rng, w, 4.0f, 9.0f);
    inv.resize(diag.size());
    for (std::size_t i = 0; i < diag.size(); ++i) inv[i] = 1.0f / diag[i];
  }

  GridRow row(bool above, bool below) const {
    GridRow r;
    r.width = static_cast<int>(diag.size());
    r.diag = diag.data();
    r.inv_diag = inv.data();
    r.wx = wx.data();
    if (below) r.wy = wy.data(), r.x_below = x_below.data();
    if (above) r.wy_above = wy_above.data(), r.x_above = x_above.data();
    return r;
  }
};

// A row of RowData split by column parity (split_row's layout).
struct SplitRowData {
  std::vector<float> b[2], diag[2], inv[2], wx[2], wy[2], wy_above[2], x_above[2], x_below[2], x[2];

  explicit SplitRowData(const RowData& d) {
    const int w = static_cast<int>(d.diag.size());
    const auto split = [w](const std::vector<float>& in, std::vector<float>(&out)[2]) {
      for (int p = 0; p < 2; ++p) {
        out[p].clear();
        for (int c = p; c < w; c += 2) out[p].push_back(in[static_cast<std::size_t>(c)]);
      }
    };
    split(d.b, b), split(d.diag, diag), split(d.inv, inv), split(d.wx, wx), split(d.wy, wy);
    split(d.wy_above, wy_above), split(d.x_above, x_above), split(d.x_below, x_below);
    split(d.x, x);
  }

  SplitSmoothRow row(int width, int parity, bool above, bool below) const {
    SplitSmoothRow r;
    r.width = width;
    r.parity = parity;
    r.b = b[parity].data();
    r.inv_diag = inv[parity].data();
    r.wx = wx[parity].data();
    r.wx_other = wx[1 - parity].data();
    r.x_other = x[1 - parity].data();
    if (below) r.wy = wy[parity].data(), r.x_below = x_below[parity].data();
    if (above) r.wy_above = wy_above[parity].data(), r.x_above = x_above[parity].data();
    return r;
  }
};

// f(w, parity, above, below) for every width of kWidths, both colours, with and without the
// rows above and below.
template <class F>
void for_each_split_case(F&& f) {
  for (const int w : kWidths)
    for (const int parity : {0, 1})
      for (const bool above : {false, true})
        for (const bool below : {false, true}) f(w, parity, above, below);
}

TEST(DensifyKernels, SmoothSplitRowIsTheSmoothRowBitForBit) {
  // The split layout changes where the operands are, not the arithmetic: every target's update of
  // a parity equals the scalar update of that colour in the plain layout.
  std::mt19937 rng(15);
  for_each_target([&] {
    for_each_split_case([&](int w, int parity, bool above, bool below) {
      const RowData data(rng, w);
      std::vector<float> expected = data.x;
      scalar::grid_smooth_row(data.row(above, below), parity, data.b.data(), expected.data());
      const SplitRowData split(data);
      const SplitSmoothRow row = split.row(w, parity, above, below);
      std::vector<float> actual = split.x[parity], reference = split.x[parity];
      grid_smooth_split_row(row, actual.data());
      scalar::grid_smooth_split_row(row, reference.data());
      ASSERT_EQ(static_cast<int>(actual.size()), parity_count(w, parity));
      for (int i = 0; i < parity_count(w, parity); ++i) {
        const float want = expected[static_cast<std::size_t>(2 * i + parity)];
        ASSERT_EQ(actual[i], want) << "w " << w << " parity " << parity << " above " << above
                                   << " below " << below << " pixel " << i;
        ASSERT_EQ(reference[i], want) << "scalar, w " << w << " pixel " << i;
      }
    });
  });
}

TEST(DensifyKernels, SplitResidualRowIsThePlainResidualBitForBit) {
  // b - A x of each colour in the split layout equals, bit for bit, b minus the plain layout's
  // grid_apply_row on every target.
  std::mt19937 rng(17);
  for_each_target([&] {
    for_each_split_case([&](int w, int parity, bool above, bool below) {
      const RowData data(rng, w);
      std::vector<float> ax(static_cast<std::size_t>(w));
      scalar::grid_apply_row(data.row(above, below), data.x.data(), ax.data());
      const SplitRowData split(data);
      const SplitResidualRow row{split.row(w, parity, above, below), split.diag[parity].data(),
                                 split.x[parity].data()};
      const int count = parity_count(w, parity);
      const float guard = 1234.5f;  // one float past the colour's pixels
      std::vector<float> actual(static_cast<std::size_t>(count) + 1, guard);
      std::vector<float> reference(static_cast<std::size_t>(count));
      split_residual_row(row, actual.data());
      scalar::split_residual_row(row, reference.data());
      ASSERT_EQ(actual.back(), guard) << "w " << w;
      for (int i = 0; i < count; ++i) {
        const std::size_t c = static_cast<std::size_t>(2 * i + parity);
        const float want = data.b[c] - ax[c];
        ASSERT_EQ(actual[static_cast<std::size_t>(i)], want)
            << "w " << w << " parity " << parity << " above " << above << " below " << below
            << " pixel " << i;
        ASSERT_EQ(reference[static_cast<std::size_t>(i)], want) << "scalar, w " << w;
      }
    });
  });
}

TEST(DensifyKernels, InverseDiagonalRowIsTheSystemsRule) {
  // 1 / diag where diag > 0, else 0 (an empty row of the system), as GridSystem keeps inv_diag.
  std::mt19937 rng(18);
  for_each_target([&] {
    for (const int n : kWidths) {
      std::vector<float> diag = random_floats(rng, n, 0.01f, 9.0f);
      for (int i = 0; i < n; i += 3) diag[static_cast<std::size_t>(i)] = i % 2 == 0 ? 0.0f : -1.0f;
      std::vector<float> inv(static_cast<std::size_t>(n) + 1, 1234.5f), reference(diag.size());
      inverse_diagonal_row(diag.data(), n, inv.data());
      scalar::inverse_diagonal_row(diag.data(), n, reference.data());
      ASSERT_EQ(inv.back(), 1234.5f) << "n " << n;
      for (int i = 0; i < n; ++i) {
        const float d = diag[static_cast<std::size_t>(i)];
        const float want = d > 0.0f ? 1.0f / d : 0.0f;
        ASSERT_EQ(inv[static_cast<std::size_t>(i)], want) << "n " << n << " i " << i;
        ASSERT_EQ(reference[static_cast<std::size_t>(i)], want) << "scalar, n " << n;
      }
    }
  });
}

TEST(DensifyKernels, SplitAndMergeRowRoundTrip) {
  std::mt19937 rng(16);
  for_each_target([&] {
    for (const int w : kWidths) {
      const std::vector<float> in = random_floats(rng, w, -5.0f, 5.0f);
      // One float past each part: a split must not write beyond its parity's pixels.
      const float guard = 1234.5f;
      std::vector<float> even(static_cast<std::size_t>(parity_count(w, 0)) + 1, guard);
      std::vector<float> odd(static_cast<std::size_t>(parity_count(w, 1)) + 1, guard);
      split_row(in.data(), w, even.data(), odd.data());
      ASSERT_EQ(even.back(), guard) << "w " << w;
      ASSERT_EQ(odd.back(), guard) << "w " << w;
      for (int c = 0; c < w; ++c)
        ASSERT_EQ((c % 2 == 0 ? even : odd)[static_cast<std::size_t>(c / 2)], in[c]) << c;
      std::vector<float> out(static_cast<std::size_t>(w) + 1, guard);
      merge_row(even.data(), odd.data(), w, out.data());
      ASSERT_EQ(out.back(), guard) << "w " << w;
      out.pop_back();
      ASSERT_EQ(out, in) << "w " << w;
    }
  });
}

TEST(DensifyKernels, SmoothSplitRowSolvesTheRowEquation) {
  // After the update, each updated pixel satisfies its own equation of A x = b exactly up to
  // rounding: diag x - Σ w x(neighbours) = b.
  std::mt19937 rng(6);
  const int w = 41;
  const RowData data(rng, w);
  const GridRow row = data.row(true, true);
  SplitRowData split(data);
  grid_smooth_split_row(split.row(w, 0, true, true), split.x[0].data());
  std::vector<float> x(static_cast<std::size_t>(w));
  merge_row(split.x[0].data(), split.x[1].data(), w, x.data());
  std::vector<float> ax(static_cast<std::size_t>(w));
  grid_apply_row(row, x.data(), ax.data());
  for (int c = 0; c < w; c += 2) EXPECT_NEAR(ax[c], data.b[c], 1e-3f) << c;
}

TEST(DensifyKernels, ApplyRowMatchesScalar) {
  std::mt19937 rng(7);
  for_each_target([&] {
    for (const int w : kWidths)
      for (const bool above : {false, true})
        for (const bool below : {false, true}) {
          const RowData data(rng, w);
          const GridRow row = data.row(above, below);
          std::vector<float> expected(static_cast<std::size_t>(w)), actual(expected.size());
          scalar::grid_apply_row(row, data.x.data(), expected.data());
          grid_apply_row(row, data.x.data(), actual.data());
          for (int c = 0; c < w; ++c)
            ASSERT_EQ(actual[c], expected[c]) << "w " << w << " column " << c;
        }
  });
}

TEST(DensifyKernels, ApplyRowIsTheStencil) {
  // Hand-computed: a 3-pixel row with a row below only.
  const float diag[] = {4, 5, 6}, wx[] = {1, 2, 0}, wy[] = {0.5f, 0.5f, 0.5f};
  const float x[] = {1, 2, 3}, below[] = {10, 20, 30};
  GridRow r;
  r.width = 3;
  r.diag = diag;
  r.wx = wx;
  r.wy = wy;
  r.x_below = below;
  float out[3];
  grid_apply_row(r, x, out);
  EXPECT_FLOAT_EQ(out[0], 4 * 1 - 1 * 2 - 0.5f * 10);
  EXPECT_FLOAT_EQ(out[1], 5 * 2 - 2 * 3 - 1 * 1 - 0.5f * 20);
  EXPECT_FLOAT_EQ(out[2], 6 * 3 - 2 * 2 - 0.5f * 30);
}

TEST(DensifyKernels, DotRowMatchesScalarAndDouble) {
  std::mt19937 rng(8);
  for_each_target([&] {
    for (const int n : {0, 1, 15, 16, 17, 31, 32, 33, 100, 1280}) {
      const std::vector<float> a = random_floats(rng, n, -3.0f, 3.0f);
      const std::vector<float> b = random_floats(rng, n, -3.0f, 3.0f);
      const double expected = scalar::dot_row(a.data(), b.data(), n);
      ASSERT_EQ(dot_row(a.data(), b.data(), n), expected) << n;
      double exact = 0;
      for (int i = 0; i < n; ++i) exact += static_cast<double>(a[i]) * b[i];
      EXPECT_NEAR(expected, exact, 1e-4 * (1 + n)) << n;
    }
  });
}

// A row of match flags (about a third missing), offset disparities on a noisy slope and their
// squares, as the densifier's match planes feed the sums.
struct MatchRow {
  std::vector<float> match, d, dd;
  MatchRow(std::mt19937& rng, int n)
      : match(static_cast<std::size_t>(n)), d(match.size()), dd(match.size()) {
    std::uniform_real_distribution<float> noise(-0.3f, 0.3f);
    for (std::size_t i = 0; i < match.size(); ++i) {
      match[i] = rng() % 3 == 0 ? 0.0f : 1.0f;
      d[i] = match[i] * (0.37f * static_cast<float>(i) - 40.0f + noise(rng));
      dd[i] = d[i] * d[i];
    }
  }
};

TEST(DensifyKernels, MatchPlaneSumsMatchScalarBitForBit) {
  std::mt19937 rng(12);
  for_each_target([&] {
    for (const int n : kWidths) {
      for (const int radius : {1, 3, 7}) {
        const MatchRow row(rng, n);
        std::vector<float> expected(6 * static_cast<std::size_t>(n), -1.0f), out(expected);
        scalar::match_plane_row_sums(row.match.data(), row.d.data(), row.dd.data(), n, radius,
                                     expected.data());
        match_plane_row_sums(row.match.data(), row.d.data(), row.dd.data(), n, radius, out.data());
        ASSERT_EQ(out, expected) << n << " " << radius;
        // Against a plain count at one pixel: Σ1 and Σu over the window.
        const int x = n / 2;
        float count = 0, su = 0;
        for (int k = -radius; k <= radius; ++k)
          if (x + k >= 0 && x + k < n)
            count += row.match[static_cast<std::size_t>(x + k)],
                su += static_cast<float>(k) * row.match[static_cast<std::size_t>(x + k)];
        EXPECT_EQ(expected[static_cast<std::size_t>(x)], count);
        EXPECT_EQ(expected[static_cast<std::size_t>(n + x)], su);
        // Ten window sums from the same row at offsets -1, 0, 1 (and none beyond, radius 2).
        std::vector<float> window(10 * static_cast<std::size_t>(n), -1.0f), window_ref(window);
        const float* rows[5] = {nullptr, expected.data(), expected.data(), expected.data(),
                                nullptr};
        scalar::match_plane_window_sums(rows, 2, n, window_ref.data());
        match_plane_window_sums(rows, 2, n, window.data());
        ASSERT_EQ(window, window_ref) << n << " " << radius;
        EXPECT_EQ(window_ref[static_cast<std::size_t>(x)], 3 * count);  // Σ1
        EXPECT_EQ(window_ref[2 * static_cast<std::size_t>(n) + static_cast<std::size_t>(x)],
                  0.0f);  // Σv
      }
    }
  });
}

// Moving the window sums down a grid gives the bits of adding each window up afresh, with rows
// missing above and below the grid as the densifier's windows have them, on every target.
TEST(DensifyKernels, MatchPlaneWindowSlideHasTheBitsOfTheWindowSums) {
  std::mt19937 rng(14);
  for_each_target([&] {
    for (const int n : kWidths)
      for (const int radius : {1, 3, 7}) {
        const int rows = 2 * radius + 9, span = 2 * radius + 1;
        std::vector<std::vector<float>> sums(static_cast<std::size_t>(rows));
        for (auto& row_sums : sums) {
          const MatchRow row(rng, n);
          row_sums.assign(6 * static_cast<std::size_t>(n), 0.0f);
          scalar::match_plane_row_sums(row.match.data(), row.d.data(), row.dd.data(), n, radius,
                                       row_sums.data());
        }
        const auto window = [&](int centre) {
          std::vector<const float*> w(static_cast<std::size_t>(span));
          for (int j = -radius; j <= radius; ++j)
            w[static_cast<std::size_t>(j + radius)] =
                centre + j >= 0 && centre + j < rows
                    ? sums[static_cast<std::size_t>(centre + j)].data()
                    : nullptr;
          return w;
        };
        std::vector<float> moved(10 * static_cast<std::size_t>(n)), moved_ref(moved), fresh(moved);
        match_plane_window_sums(window(0).data(), radius, n, moved.data());
        moved_ref = moved;
        for (int centre = 1; centre < rows; ++centre) {
          const float* left = centre - 1 - radius >= 0
                                  ? sums[static_cast<std::size_t>(centre - 1 - radius)].data()
                                  : nullptr;
          match_plane_window_slide(window(centre).data(), left, radius, n, moved.data());
          scalar::match_plane_window_slide(window(centre).data(), left, radius, n,
                                           moved_ref.data());
          scalar::match_plane_window_sums(window(centre).data(), radius, n, fresh.data());
          ASSERT_EQ(moved_ref, fresh) << n << " radius " << radius << " centre " << centre;
          ASSERT_EQ(moved, fresh) << n << " radius " << radius << " centre " << centre;
        }
      }
  });
}

TEST(DensifyKernels, MatchPlaneIsTheLeastSquaresPlaneAndMatchesScalar) {
  std::mt19937 rng(13);
  // Windows of 7x7 on planes d = c + a u + b v with some matches missing, some noisy: the sums
  // built directly, the plane's value at the centre against a fit in double.
  constexpr int n = 37;
  std::vector<float> sums(10 * static_cast<std::size_t>(n)), own(n);
  std::vector<double> expected(n);
  std::uniform_real_distribution<double> coef(-2.0, 2.0), noise(-0.2, 0.2);
  for (int i = 0; i < n; ++i) {
    const double c = 20 * coef(rng), a = coef(rng), b = coef(rng);
    const double amp = i % 5 == 0 ? 8.0 : 1.0;  // every fifth window far off any plane
    double s[10] = {};
    for (int v = -3; v <= 3; ++v)
      for (int u = -3; u <= 3; ++u) {
        if (rng() % 4 == 0) continue;
        const double d = c + a * u + b * v + amp * noise(rng);
        const double t[10] = {1, double(u), double(v), double(u * u), double(u * v), double(v * v),
                              d, u * d,     v * d,     d * d};
        for (int k = 0; k < 10; ++k) s[k] += t[k];
      }
    for (int k = 0; k < 10; ++k)
      sums[static_cast<std::size_t>(k * n + i)] = static_cast<float>(s[k]);
    own[static_cast<std::size_t>(i)] = i % 7 == 3 ? std::numeric_limits<float>::infinity() : 50.0f;
    // Least squares in double: normal equations centred at the mean.
    const double N = s[0], mu = s[1] / N, mv = s[2] / N, md = s[6] / N;
    const double cuu = s[3] - N * mu * mu, cuv = s[4] - N * mu * mv, cvv = s[5] - N * mv * mv;
    const double cud = s[7] - N * mu * md, cvd = s[8] - N * mv * md, cdd = s[9] - N * md * md;
    const double det = cuu * cvv - cuv * cuv;
    const double pa = (cvv * cud - cuv * cvd) / det, pb = (cuu * cvd - cuv * cud) / det;
    const double rms2 = (cdd - pa * cud - pb * cvd) / N;
    expected[static_cast<std::size_t>(i)] =
        own[static_cast<std::size_t>(i)] < 1e30f && rms2 <= 0.6 * 0.6
            ? 100.0 + md - pa * mu - pb * mv
            : std::nan("");
  }
  const MatchPlaneRule rule{100.0f, 49.0f / 4.0f, 0.36f};
  std::vector<float> reference(n);
  scalar::match_plane_row(sums.data(), own.data(), n, rule, reference.data());
  int kept = 0;
  for (int i = 0; i < n; ++i) {
    const double e = expected[static_cast<std::size_t>(i)];
    const float r = reference[static_cast<std::size_t>(i)];
    if (std::isnan(e)) {
      EXPECT_TRUE(std::isnan(r)) << i;
    } else {
      EXPECT_NEAR(r, e, 1e-3) << i;
      ++kept;
    }
  }
  EXPECT_GT(kept, n / 2);
  EXPECT_LT(kept, n);
  for_each_target([&] {
    std::vector<float> out(n, 0.0f);
    match_plane_row(sums.data(), own.data(), n, rule, out.data());
    for (int i = 0; i < n; ++i) {
      const float a = out[static_cast<std::size_t>(i)], b = reference[static_cast<std::size_t>(i)];
      ASSERT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << i;
    }
  });
}

// Each input pixel that holds its grid pixel's own value takes the grid pixel's plane where one
// was kept; other values (the boundary refinement's, holes) and pixels without a plane stay.
TEST(DensifyKernels, MatchPlaneSelectHalfRowTakesThePlaneOnlyWhereTheGridValueIs) {
  std::mt19937 rng(17);
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const int w : kWidths) {
    const int n = (w + 1) / 2;
    std::vector<float> own(n), plane(n), sparse(w);
    for (int i = 0; i < n; ++i) {
      own[i] = rng() % 5 == 0 ? inf : 10.0f + static_cast<float>(rng() % 50);
      plane[i] = rng() % 3 == 0 ? nan : own[i] + 0.25f;
    }
    for (int x = 0; x < w; ++x)
      sparse[x] = rng() % 4 == 0 ? own[x / 2] + 1.0f : rng() % 7 == 0 ? inf : own[x / 2];
    std::vector<float> reference(w);
    scalar::match_plane_select_half_row(sparse.data(), own.data(), plane.data(), w,
                                        reference.data());
    for (int x = 0; x < w; ++x) {
      const bool takes = sparse[x] == own[x / 2] && !std::isnan(plane[x / 2]);
      ASSERT_EQ(reference[x], takes ? plane[x / 2] : sparse[x]) << "w " << w << " x " << x;
    }
    for_each_target([&] {
      std::vector<float> out(static_cast<std::size_t>(w) + 1, -7.0f);
      match_plane_select_half_row(sparse.data(), own.data(), plane.data(), w, out.data());
      for (int x = 0; x < w; ++x) ASSERT_EQ(out[x], reference[x]) << "w " << w << " x " << x;
      EXPECT_EQ(out[w], -7.0f) << "nothing past the row";
    });
  }
}

TEST(DensifyKernels, EdgeWeightsMatchScalar) {
  std::mt19937 rng(9);
  std::vector<float> colour(256);
  for (int d = 0; d < 256; ++d) colour[static_cast<std::size_t>(d)] = 1.0f / (1.0f + 0.1f * d);
  // The densifier's table with color_sigma 1: below the floor from a difference of 7 on, so the
  // weights of the smaller differences come from registers where a vector has 8 lanes or more.
  std::vector<float> steep(256);
  for (int d = 0; d < 256; ++d)
    steep[static_cast<std::size_t>(d)] = std::exp(-static_cast<float>(d));
  EXPECT_EQ(colour_floor_from(colour.data(), 0.01f), 256);
  EXPECT_EQ(colour_floor_from(steep.data(), 0.001f), 7);
  EXPECT_EQ(colour_floor_from(steep.data(), 2.0f), 0);
  for_each_target([&] {
    for (const int n : kWidths) {
      std::vector<std::uint8_t> bar_a(static_cast<std::size_t>(n)), bar_b(bar_a.size());
      std::vector<std::uint8_t> grey_a(bar_a.size()), grey_b(bar_a.size());
      for (std::size_t i = 0; i < bar_a.size(); ++i) {
        bar_a[i] = rng() % 4 == 0;
        bar_b[i] = rng() % 4 == 0;
        grey_a[i] = static_cast<std::uint8_t>(rng());
        grey_b[i] = static_cast<std::uint8_t>(rng());
      }
      // Strengths up to 1 (weight 0, so the floor applies), many near 0 (so that the colour
      // weight decides) and some equal pairs; grey-level differences of 0 to 12 on most pixels.
      std::vector<float> str_a = random_floats(rng, n, 0.0f, 1.0f);
      std::vector<float> str_b = random_floats(rng, n, 0.0f, 1.0f);
      for (std::size_t i = 0; i < str_a.size(); i += 3) str_b[i] = str_a[i];
      for (std::size_t i = 1; i < str_a.size(); i += 2) str_a[i] *= 0.01f, str_b[i] *= 0.01f;
      for (std::size_t i = 0; i < grey_a.size(); ++i) {
        if (rng() % 4 == 0) continue;
        const int near = grey_a[i] + static_cast<int>(rng() % 25) - 12;
        grey_b[i] = static_cast<std::uint8_t>(std::clamp(near, 0, 255));
      }
      const EdgeEnds ends{bar_a.data(), bar_b.data(),  str_a.data(),
                          str_b.data(), grey_a.data(), grey_b.data()};
      struct Case {
        const float* table;
        float floor;
      };
      const Case cases[] = {{nullptr, 0.01f}, {colour.data(), 0.01f}, {steep.data(), 0.001f}};
      for (const Case& c : cases) {
        const EdgeRule rule{2.4f, c.floor, c.table,
                            c.table ? colour_floor_from(c.table, c.floor) : 256};
        std::vector<float> expected(bar_a.size()), out(bar_a.size(), -1.0f);
        scalar::edge_weights_row(ends, rule, n, expected.data());
        edge_weights_row(ends, rule, n, out.data());
        ASSERT_EQ(out, expected) << "n " << n << (c.table ? " with" : " without")
                                 << " guidance, floor " << c.floor;
        for (std::size_t i = 0; i < out.size(); ++i) {
          if (bar_a[i] != bar_b[i]) {
            ASSERT_EQ(out[i], 2.4f * c.floor) << "a barrier between the ends cuts the edge";
          } else {
            ASSERT_GE(out[i], 2.4f * c.floor);
            ASSERT_LE(out[i], 2.4f);
          }
        }
      }
    }
  });
}

// A strength that is not finite at either end of an edge makes its weight NaN (unless a barrier
// cuts the edge), in every kernel as in the scalar twin: the solve then says it found no finite
// solution, on the half-size path too.
TEST(DensifyKernels, EdgeWeightsCarryANaNFromEitherEnd) {
  std::mt19937 rng(11);
  for_each_target([&] {
    for (const int n : kWidths) {
      const auto size = static_cast<std::size_t>(n);
      std::vector<std::uint8_t> bar_a(size), bar_b(size), grey(size, 100);
      std::vector<float> str_a = random_floats(rng, n, 0.0f, 1.0f);
      std::vector<float> str_b = random_floats(rng, n, 0.0f, 1.0f);
      for (std::size_t i = 0; i < size; ++i) {
        bar_a[i] = i % 11 == 3;
        if (i % 5 == 1) str_a[i] = std::numeric_limits<float>::quiet_NaN();
        if (i % 7 == 2) str_b[i] = std::numeric_limits<float>::quiet_NaN();
      }
      const EdgeEnds ends{bar_a.data(), bar_b.data(), str_a.data(),
                          str_b.data(), grey.data(),  grey.data()};
      const EdgeRule rule{2.4f, 0.01f, nullptr, 256};
      std::vector<float> expected(size), out(size, -1.0f);
      scalar::edge_weights_row(ends, rule, n, expected.data());
      edge_weights_row(ends, rule, n, out.data());
      for (std::size_t i = 0; i < size; ++i) {
        const bool nan = !bar_a[i] && (std::isnan(str_a[i]) || std::isnan(str_b[i]));
        ASSERT_EQ(std::isnan(expected[i]), nan) << "scalar, n " << n << " at " << i;
        ASSERT_EQ(std::isnan(out[i]), nan) << "n " << n << " at " << i;
        if (!nan) {
          ASSERT_EQ(out[i], expected[i]) << "n " << n << " at " << i;
        }
      }
    }
  });
}

TEST(DensifyKernels, EdgeWeightIsThePaperWeightTimesTheGuidance) {
  const std::uint8_t no_bar[2] = {0, 0}, bar[2] = {1, 0};
  const float str_a[2] = {0.25f, 0.9f}, str_b[2] = {0.5f, 0.995f};
  const std::uint8_t grey_a[2] = {100, 0}, grey_b[2] = {103, 0};
  const float colour[256] = {1.0f, 0.5f, 0.25f, 0.125f};
  float out[2];
  scalar::edge_weights_row({no_bar, no_bar, str_a, str_b, grey_a, grey_b}, {2.0f, 0.01f, colour}, 2,
                           out);
  EXPECT_FLOAT_EQ(out[0], 2.0f * (1.0f - 0.25f) * 0.125f);  // min strength, |100 - 103| = 3
  EXPECT_FLOAT_EQ(out[1], 2.0f * 0.1f);                     // 1 - 0.9, no grey difference
  scalar::edge_weights_row({no_bar, no_bar, str_b, str_b, grey_a, grey_b}, {2.0f, 0.01f, nullptr},
                           2, out);
  EXPECT_FLOAT_EQ(out[1], 2.0f * 0.01f);  // 1 - 0.995 is below the floor
  scalar::edge_weights_row({bar, no_bar, str_a, str_b, grey_a, grey_b}, {2.0f, 0.01f, colour}, 2,
                           out);
  EXPECT_FLOAT_EQ(out[0], 2.0f * 0.01f);
}

// Sparse, hint and previous values as the densifier meets them: known ones, holes (+inf), a NaN,
// zeros and negatives; with and without the previous frame and the hint weight.
TEST(DensifyKernels, DataTermsRowMatchesScalarAndTheRule) {
  std::mt19937 rng(21);
  const float inf = std::numeric_limits<float>::infinity();
  const auto values = [&](int w) {
    std::vector<float> v = random_floats(rng, w, 0.5f, 90.0f);
    for (float& e : v) {
      const unsigned pick = rng() % 8;
      if (pick == 0) e = inf;
      if (pick == 1) e = 0.0f;
      if (pick == 2) e = -e;
      if (pick == 3) e = std::numeric_limits<float>::quiet_NaN();
    }
    return v;
  };
  const auto known = [inf](float v) { return v > 0.0f && v < inf; };
  for (const int w : kWidths)
    for (const bool with_previous : {false, true})
      for (const float hint_weight : {0.0f, 0.04f}) {
        const std::vector<float> sparse = values(w), previous = values(w);
        std::vector<float> hint = random_floats(rng, w, 1.0f, 60.0f);
        for (float& e : hint) e = rng() % 3 == 0 ? 0.0f : e;
        const DataTermRule rule{1e-6f, 0.8f, hint_weight, 0.02f};
        const float* prev = with_previous ? previous.data() : nullptr;
        std::vector<float> data(static_cast<std::size_t>(w)), b(data.size());
        float low = inf, high = 0.0f;
        scalar::data_terms_row(sparse.data(), hint.data(), prev, w, rule, data.data(), b.data(),
                               &low, &high);
        float want_low = inf, want_high = 0.0f;
        for (int x = 0; x < w; ++x) {
          float a = rule.regulariser, r = 0.0f;
          if (known(sparse[x])) {
            a += rule.lambda_d, r += rule.lambda_d * sparse[x];
            want_low = std::min(want_low, sparse[x]), want_high = std::max(want_high, sparse[x]);
          } else if (hint[x] > 0.0f) {
            a += hint_weight, r += hint_weight * hint[x];
          }
          if (prev && known(prev[x])) {
            a += rule.lambda_s2, r += rule.lambda_s2 * prev[x];
            want_low = std::min(want_low, prev[x]), want_high = std::max(want_high, prev[x]);
          }
          // The rule written out here may be compiled with fused multiply-adds (aarch64):
          // equal to a few ulp; the kernels are compared bit for bit below.
          ASSERT_FLOAT_EQ(data[x], a) << x;
          ASSERT_FLOAT_EQ(b[x], r) << x;
        }
        ASSERT_EQ(low, want_low);
        ASSERT_EQ(high, want_high);
        for_each_target([&] {
          std::vector<float> out_data(data.size(), -1.0f), out_b(data.size(), -1.0f);
          float out_low = inf, out_high = 0.0f;
          data_terms_row(sparse.data(), hint.data(), prev, w, rule, out_data.data(), out_b.data(),
                         &out_low, &out_high);
          ASSERT_EQ(out_data, data) << "width " << w;
          ASSERT_EQ(out_b, b) << "width " << w;
          ASSERT_EQ(out_low, low) << "width " << w;
          ASSERT_EQ(out_high, high) << "width " << w;
        });
      }
}

// The hole hint as hole_hint_row states it, searched out pixel by pixel; `untouched` for a known
// pixel, whose entry it does not write.
float hole_hint_by_search(const std::vector<float>& sparse, const std::vector<float>& wx, int x,
                          float crossing, float untouched) {
  const auto known = [&](int i) {
    return sparse[i] > 0.0f && sparse[i] < std::numeric_limits<float>::infinity();
  };
  if (known(x)) return untouched;
  const int w = static_cast<int>(sparse.size());
  int l = x - 1, r = x + 1;
  while (l >= 0 && !known(l)) --l;
  while (r < w && !known(r)) ++r;
  if (l < 0 && r >= w) return 0.0f;
  if (l < 0) return sparse[r];
  if (r >= w) return sparse[l];
  bool left_crossed = false, right_crossed = false;
  for (int j = l; j < x; ++j) left_crossed = left_crossed || wx[j] < crossing;
  for (int j = x; j < r; ++j) right_crossed = right_crossed || wx[j] < crossing;
  if (left_crossed == right_crossed) return std::min(sparse[l], sparse[r]);
  return left_crossed ? sparse[r] : sparse[l];
}

TEST(DensifyKernels, HoleHintRowMatchesScalarAndTheRule) {
  std::mt19937 rng(17);
  const float inf = std::numeric_limits<float>::infinity();
  const float crossing = 0.12f;
  std::vector<int> widths = kWidths;
  widths.push_back(1283);
  for (const int w : widths)
    for (const double known_share : {0.0, 0.03, 0.3, 0.8, 0.97, 1.0})
      for (const double weak_share : {0.0, 0.1, 0.5}) {
        std::vector<float> sparse = random_floats(rng, w, 0.5f, 90.0f);
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        for (float& e : sparse) {
          if (unit(rng) < known_share) continue;
          const unsigned pick = rng() % 4;
          e = pick == 0 ? inf : pick == 1 ? 0.0f : pick == 2 ? -e : std::nanf("");
        }
        std::vector<float> wx = random_floats(rng, w, crossing, 2.4f);
        for (float& e : wx)
          if (unit(rng) < weak_share) e = crossing * static_cast<float>(unit(rng));
        wx.back() = 0.0f;  // the edge past the row end is not an edge
        std::vector<float> want(static_cast<std::size_t>(w));
        for (int x = 0; x < w; ++x) want[x] = hole_hint_by_search(sparse, wx, x, crossing, -7.0f);
        std::vector<float> hint(want.size(), -7.0f);
        scalar::hole_hint_row(sparse.data(), wx.data(), w, crossing, hint.data());
        ASSERT_EQ(hint, want) << "width " << w << " known " << known_share;
        for_each_target([&] {
          std::vector<float> out(want.size(), -7.0f);
          hole_hint_row(sparse.data(), wx.data(), w, crossing, out.data());
          ASSERT_EQ(out, want) << "width " << w << " known " << known_share << " weak "
                               << weak_share;
        });
      }
}

TEST(DensifyKernels, OcclusionFillRowMatchesScalarAndTheRule) {
  std::mt19937 rng(23);
  const float inf = std::numeric_limits<float>::infinity();
  const OcclusionRule with_strips{1.6f, 0.04f}, without_strips{0.0f, 0.04f};
  std::vector<int> widths = kWidths;
  widths.push_back(1283);
  int weighted_rows = 0, merged_runs = 0, dropped_hints = 0;
  for (const int w : widths)
    for (int trial = 0; trial < 12; ++trial) {
      // Alternating runs of matches (a few levels, so that jumps repeat) and holes of any width
      // from 0 to 40, the holes in every encoding of "unknown".
      std::vector<float> sparse;
      const float levels[] = {8.0f, 12.5f, 20.0f, 31.0f, 45.25f};
      while (static_cast<int>(sparse.size()) < w) {
        const float level = levels[rng() % 5];
        for (int i = 1 + static_cast<int>(rng() % 4); i > 0; --i) sparse.push_back(level);
        for (int i = static_cast<int>(rng() % 41) * static_cast<int>(rng() % 2); i > 0; --i) {
          const unsigned pick = rng() % 4;
          sparse.push_back(pick == 0 ? inf : pick == 1 ? 0.0f : pick == 2 ? -3.0f : std::nanf(""));
        }
      }
      sparse.resize(static_cast<std::size_t>(w));
      if (trial % 3 == 0) sparse[0] = inf;  // a run at the row start
      const std::vector<float> data0 = random_floats(rng, w, 0.0f, 1.0f);
      const std::vector<float> b0 = random_floats(rng, w, 0.0f, 40.0f);
      // Hints as hole_hint_row gives them, a quarter of them none (0).
      std::vector<float> hint = random_floats(rng, w, 1.0f, 50.0f);
      for (float& v : hint)
        if (rng() % 4 == 0) v = 0.0f;
      // Every fourth row without strips (densify.occlusion_fill 0): only the hints drop.
      const OcclusionRule& rule = trial % 4 == 3 ? without_strips : with_strips;
      std::vector<float> want_data = data0, want_b = b0;
      int want_count = 0;
      const std::vector<float> targets =
          occlusion_targets(sparse, &merged_runs, rule.weight > 0.0f);
      for (int x = 0; x < w; ++x) {
        const float far = targets[x];
        if (far == kNoHint) {
          if (hint[x] > 0.0f) {
            want_data[x] -= rule.hint_weight;
            const volatile float hint_pull = rule.hint_weight * hint[x];
            want_b[x] -= hint_pull;
            ++dropped_hints;
          }
          continue;
        }
        if (far == 0.0f) continue;
        want_data[x] += rule.weight;
        // Rounded before the sum, as in the kernels (built without contraction); this file may
        // fuse a * b + c otherwise (aarch64 does).
        const volatile float pull = rule.weight * far;
        want_b[x] += pull;
        ++want_count;
      }
      weighted_rows += want_count > 0;
      std::vector<float> data = data0, b = b0;
      ASSERT_EQ(
          scalar::occlusion_fill_row(sparse.data(), hint.data(), w, rule, data.data(), b.data()),
          want_count);
      ASSERT_EQ(data, want_data) << "width " << w;
      ASSERT_EQ(b, want_b) << "width " << w;
      for_each_target([&] {
        std::vector<float> out_data = data0, out_b = b0;
        ASSERT_EQ(
            occlusion_fill_row(sparse.data(), hint.data(), w, rule, out_data.data(), out_b.data()),
            want_count);
        ASSERT_EQ(out_data, want_data) << "width " << w << " trial " << trial;
        ASSERT_EQ(out_b, want_b) << "width " << w << " trial " << trial;
      });
    }
  EXPECT_GT(weighted_rows, 20);  // the rows do hold occlusion runs
  EXPECT_GT(merged_runs, 5);     // ... and runs split by a few matches
  EXPECT_GT(dropped_hints, 20);  // ... and holes that drop their hints
}

TEST(DensifyKernels, DiagonalRowMatchesScalar) {
  std::mt19937 rng(22);
  for (const int w : kWidths)
    for (const int edges : {0, 1, 2, 3}) {  // bit 0: a row below, bit 1: a row above
      std::vector<float> data = random_floats(rng, w, 0.0f, 1.0f);
      std::vector<float> wx = random_floats(rng, w, 0.0f, 2.0f);
      std::vector<float> wy = random_floats(rng, w, 0.0f, 2.0f);
      std::vector<float> wy_above = random_floats(rng, w, 0.0f, 2.0f);
      if (w > 2) {  // pixel 1 without data or edges: diagonal 0, inverse 0
        data[1] = wx[0] = wx[1] = wy[1] = wy_above[1] = 0.0f;
      }
      const float* below = edges & 1 ? wy.data() : nullptr;
      const float* above = edges & 2 ? wy_above.data() : nullptr;
      std::vector<float> diag(static_cast<std::size_t>(w)), inv(diag.size());
      scalar::diagonal_row(data.data(), wx.data(), below, above, w, diag.data(), inv.data());
      if (w > 2) {
        ASSERT_EQ(inv[1], 0.0f);
      }
      for_each_target([&] {
        std::vector<float> out_diag(diag.size(), -1.0f), out_inv(diag.size(), -1.0f);
        diagonal_row(data.data(), wx.data(), below, above, w, out_diag.data(), out_inv.data());
        ASSERT_EQ(out_diag, diag) << "width " << w << " edges " << edges;
        ASSERT_EQ(out_inv, inv) << "width " << w << " edges " << edges;
      });
    }
}

}  // namespace
}  // namespace dco::kernels
