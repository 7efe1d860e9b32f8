// SIMD versions of the contour stage's image filters, compiled once per Highway target and
// dispatched at run time. The interior columns go by whole vectors; the clamped borders and the
// last partial vector go to the scalar range functions, so the results equal
// dco::kernels::scalar bit for bit (the file is built without floating-point contraction).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/filter_kernels.hpp"
#include "filter_ranges.hpp"
#include "vector_cover.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "filter_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void Gaussian5VerticalRow(const std::uint8_t* const rows[5], const float* taps, int width,
                          float* out) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(df)> du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto load = [&](int k, int x) {
    return hn::ConvertTo(df, hn::PromoteTo(di, hn::LoadU(du8, rows[k] + x)));
  };
  const auto t0 = hn::Set(df, taps[0]), t1 = hn::Set(df, taps[1]), t2 = hn::Set(df, taps[2]);
  int x = 0;
  for (; x + n <= width; x += n) {
    // taps[0] * (a + e) + taps[1] * (b + d) + taps[2] * c, as pixel::gaussian5_vertical.
    const auto outer = hn::Mul(t0, hn::Add(load(0, x), load(4, x)));
    const auto inner = hn::Mul(t1, hn::Add(load(1, x), load(3, x)));
    hn::StoreU(hn::Add(hn::Add(outer, inner), hn::Mul(t2, load(2, x))), df, out + x);
  }
  detail::gaussian5_vertical_range(rows, taps, x, width, out);
}

void RowFilter(const float* in, int width, const float* taps, int radius, float* out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  // Columns whose taps all fall inside the row.
  const int begin = std::min(radius, width);
  const int end = std::max(begin, width - radius);
  detail::row_filter_range(in, width, taps, radius, 0, begin, out);
  const auto filter = [&](int at) {
    const float* src = in + at - radius;
    auto sum = hn::Zero(d);
    for (int k = 0; k <= 2 * radius; ++k)
      sum = hn::Add(sum, hn::Mul(hn::Set(d, taps[k]), hn::LoadU(d, src + k)));
    hn::StoreU(sum, d, out + at);
  };
  const int done = detail::cover_with_vectors(begin, end, n, filter);  // out is not an input
  detail::row_filter_range(in, width, taps, radius, done, width, out);
}

void BoxVerticalRow(const float* in, std::ptrdiff_t stride, int height, int y, int size, float inv,
                    int width, float* out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto scale = hn::Set(d, inv);
  const int top = y - size / 2;
  const auto row = [&](int k) { return in + pixel::clamp_to(top + k, 0, height - 1) * stride; };
  int x = 0;
  for (; x + n <= width; x += n) {
    // The first row, then each further one added in order, then the scale: box_column_mean.
    auto sum = hn::LoadU(d, row(0) + x);
    for (int k = 1; k < size; ++k) sum = hn::Add(sum, hn::LoadU(d, row(k) + x));
    hn::StoreU(hn::Mul(sum, scale), d, out + x);
  }
  detail::box_vertical_range(in, stride, height, y, size, inv, x, width, out);
}

void SobelRow(const SobelRows& r, float inv_norm, float* magnitude, std::uint8_t* direction) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(df)> du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const int w = r.width;
  const auto two = hn::Set(df, 2.0f);
  const auto inv = hn::Set(df, inv_norm);
  const auto tan22 = hn::Set(df, pixel::kTan22);  // pixel::gradient_direction's sector borders
  const auto tan67 = hn::Set(df, pixel::kTan67);
  const auto zero = hn::Zero(df);
  const auto sector_h = hn::Set(di, 0), sector_v = hn::Set(di, 2);
  const auto sector_down = hn::Set(di, 1), sector_up = hn::Set(di, 3);
  // Columns 1 .. w - 2 have both neighbours; column 0 and w - 1 clamp.
  const int end = std::max(1, w - 1);
  detail::sobel_range(r, inv_norm, 0, std::min(1, w), magnitude, direction);
  const auto gradient = [&](int x) {
    const auto column = [&](const float* row, int offset) {
      return hn::LoadU(df, row + x + offset);
    };
    // (up + 2 mid + down) on the right minus the same on the left, as pixel::sobel_gx.
    const auto right =
        hn::Add(hn::Add(column(r.up, 1), hn::Mul(two, column(r.mid, 1))), column(r.down, 1));
    const auto left =
        hn::Add(hn::Add(column(r.up, -1), hn::Mul(two, column(r.mid, -1))), column(r.down, -1));
    const auto gx = hn::Sub(right, left);
    const auto below =
        hn::Add(hn::Add(column(r.down, -1), hn::Mul(two, column(r.down, 0))), column(r.down, 1));
    const auto above =
        hn::Add(hn::Add(column(r.up, -1), hn::Mul(two, column(r.up, 0))), column(r.up, 1));
    const auto gy = hn::Sub(below, above);
    hn::StoreU(hn::Mul(hn::Sqrt(hn::Add(hn::Mul(gx, gx), hn::Mul(gy, gy))), inv), df,
               magnitude + x);
    const auto ax = hn::Abs(gx);
    const auto ay = hn::Abs(gy);
    const auto diagonal = hn::IfThenElse(
        hn::RebindMask(di, hn::Xor(hn::Gt(gx, zero), hn::Gt(gy, zero))), sector_up, sector_down);
    const auto sector = hn::IfThenElse(
        hn::RebindMask(di, hn::Le(ay, hn::Mul(ax, tan22))), sector_h,
        hn::IfThenElse(hn::RebindMask(di, hn::Ge(ay, hn::Mul(ax, tan67))), sector_v, diagonal));
    hn::StoreU(hn::DemoteTo(du8, sector), du8, direction + x);
  };
  // The outputs are not inputs.
  const int done = detail::cover_with_vectors(1, end, n, gradient);
  detail::sobel_range(r, inv_norm, std::min(done, w), w, magnitude, direction);
}

// Sorts five vectors lane by lane (a network of nine compare-exchanges).
template <class V>
HWY_INLINE void Sort5(V& a, V& b, V& c, V& d, V& e) {
  const auto exchange = [](V& lo, V& hi) {
    const V min = hn::Min(lo, hi);
    hi = hn::Max(lo, hi);
    lo = min;
  };
  exchange(a, b), exchange(d, e), exchange(c, e), exchange(c, d), exchange(a, d);
  exchange(a, c), exchange(b, e), exchange(b, d), exchange(b, c);
}

// Sorts four vectors lane by lane (five compare-exchanges).
template <class V>
HWY_INLINE void Sort4(V& a, V& b, V& c, V& d) {
  const auto exchange = [](V& lo, V& hi) {
    const V min = hn::Min(lo, hi);
    hi = hn::Max(lo, hi);
    lo = min;
  };
  exchange(a, b), exchange(c, d), exchange(a, c), exchange(b, d), exchange(b, c);
}

// The 25 values of a window as a 5x5 matrix, each column sorted, then each row: the matrix is
// then sorted along both, so element (i, j) has at least (i + 1)(j + 1) - 1 others at or below
// it and (5 - i)(5 - j) - 1 at or above it. Six elements are then below the median for sure and
// six above; the median is the 7th smallest of the other 13: the top two of row 0, the top
// three of row 1, the middle three of row 2, the bottom three of row 3 and the bottom two of
// row 4. Sorted runs of those merge with the rule that the k-th smallest of two sorted runs x
// and y is the least over i + j = k of max(x_i, y_j) (x_0 = y_0 = -inf).
// The columns are sorted once per row, the even and the odd ones apart, so that the outputs at
// 2i and 2i + 1 (one vector of each) share four of their five columns: each row of the matrix
// sorts those four once, and each output inserts its fifth column into them.
void Median5Row(const float* const rows[5], int width, float* columns, float* out) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const int n = static_cast<int>(hn::Lanes(d));
  const int pairs = width / 2;  // of columns 2i, 2i + 1 both inside the row
  if (pairs < n) {
    detail::median5_range(rows, width, 0, width, out);
    return;
  }
  // Rank k of column x, the row's ends replicated two columns out: padded column q = x + 2 is
  // even[k][q / 2] or odd[k][q / 2].
  const int half = median5_columns(width) / 10;
  float* even[5];
  float* odd[5];
  for (int k = 0; k < 5; ++k) {
    even[k] = columns + 2 * k * half;
    odd[k] = even[k] + half;
  }
  const auto slot = [&](int k, int x) -> float& {
    const int q = x + 2;
    return (q & 1 ? odd : even)[k][q >> 1];
  };
  // Columns 2m .. 2m + 2n - 1 (the outputs are not the inputs, so the overlapping last vector
  // stores the same values again); an odd width leaves its last column.
  detail::cover_with_vectors(0, pairs, n, [&](int m) {
    V e0, o0, e1, o1, e2, o2, e3, o3, e4, o4;
    hn::LoadInterleaved2(d, rows[0] + 2 * m, e0, o0);
    hn::LoadInterleaved2(d, rows[1] + 2 * m, e1, o1);
    hn::LoadInterleaved2(d, rows[2] + 2 * m, e2, o2);
    hn::LoadInterleaved2(d, rows[3] + 2 * m, e3, o3);
    hn::LoadInterleaved2(d, rows[4] + 2 * m, e4, o4);
    Sort5(e0, e1, e2, e3, e4);
    Sort5(o0, o1, o2, o3, o4);
    hn::StoreU(e0, d, even[0] + m + 1), hn::StoreU(o0, d, odd[0] + m + 1);
    hn::StoreU(e1, d, even[1] + m + 1), hn::StoreU(o1, d, odd[1] + m + 1);
    hn::StoreU(e2, d, even[2] + m + 1), hn::StoreU(o2, d, odd[2] + m + 1);
    hn::StoreU(e3, d, even[3] + m + 1), hn::StoreU(o3, d, odd[3] + m + 1);
    hn::StoreU(e4, d, even[4] + m + 1), hn::StoreU(o4, d, odd[4] + m + 1);
  });
  if (width > 2 * pairs) {
    const int x = width - 1;
    float v[5] = {rows[0][x], rows[1][x], rows[2][x], rows[3][x], rows[4][x]};
    std::sort(v, v + 5);
    for (int k = 0; k < 5; ++k) slot(k, x) = v[k];
  }
  for (int k = 0; k < 5; ++k) {
    slot(k, -2) = slot(k, -1) = slot(k, 0);
    slot(k, width) = slot(k, width + 1) = slot(k, width - 1);
  }
  const auto max = [](V p, V q) { return hn::Max(p, q); };
  const auto min = [](V p, V q) { return hn::Min(p, q); };
  // The 13 candidates of one output into its median (see above).
  const auto median_of = [&](V a1, V a2, V b1, V b2, V b3, V c1, V c2, V c3, V d1, V d2, V d3, V e1,
                             V e2) {
    // Rows 0 and 4 (two candidates each) into u, four sorted; row 3 joins it: t, seven.
    const V u1 = min(a1, e1), u2 = min(max(a1, e1), min(a2, e2));
    const V u3 = min(max(a2, e1), max(a1, e2)), u4 = max(a2, e2);
    const V t1 = min(u1, d1);
    const V t2 = min(min(u2, d2), max(u1, d1));
    const V t3 = min(min(u3, d3), min(max(u2, d1), max(u1, d2)));
    const V t4 = min(min(u4, max(u3, d1)), min(max(u2, d2), max(u1, d3)));
    const V t5 = min(max(u4, d1), min(max(u3, d2), max(u2, d3)));
    const V t6 = min(max(u4, d2), max(u3, d3));
    const V t7 = max(u4, d3);
    // Rows 1 and 2 (three each) into s, six sorted.
    const V s1 = min(b1, c1);
    const V s2 = min(max(b1, c1), min(b2, c2));
    const V s3 = min(min(b3, c3), min(max(b2, c1), max(b1, c2)));
    const V s4 = min(max(b3, c1), min(max(b2, c2), max(b1, c3)));
    const V s5 = min(max(b3, c2), max(b2, c3));
    const V s6 = max(b3, c3);
    // The 7th smallest of s and t.
    V median = min(t7, max(s1, t6));
    median = min(median, min(max(s2, t5), max(s3, t4)));
    return min(median, min(max(s4, t3), min(max(s5, t2), max(s6, t1))));
  };
  // Outputs 2i and 2i + 1 for i = i0 .. i0 + n - 1.
  detail::cover_with_vectors(0, pairs, n, [&](int i0) {
    // Output 2i reads padded columns 2i .. 2i + 4, output 2i + 1 columns 2i + 1 .. 2i + 5: both
    // read s = columns 2i + 1 .. 2i + 4 (sorted per row below), the first also column 2i (p),
    // the second column 2i + 5 (q). Ranks r of a row after inserting x into sorted s:
    // r0 = min(s0, x), r_j = min(s_j, max(s_(j-1), x)), r4 = max(s3, x).
    // (Sizeless SVE vectors cannot be captured: the lambda takes them as parameters.)
    const auto row = [&](int k, V& s0, V& s1, V& s2, V& s3, V& p, V& q) {
      s0 = hn::LoadU(d, odd[k] + i0), s1 = hn::LoadU(d, even[k] + i0 + 1);
      s2 = hn::LoadU(d, odd[k] + i0 + 1), s3 = hn::LoadU(d, even[k] + i0 + 2);
      p = hn::LoadU(d, even[k] + i0), q = hn::LoadU(d, odd[k] + i0 + 2);
      Sort4(s0, s1, s2, s3);
    };
    V s0, s1, s2, s3, p, q;
    row(0, s0, s1, s2, s3, p, q);  // ranks 3 and 4
    const V a1p = min(s3, max(s2, p)), a2p = max(s3, p);
    const V a1q = min(s3, max(s2, q)), a2q = max(s3, q);
    row(1, s0, s1, s2, s3, p, q);  // ranks 2, 3 and 4
    const V b1p = min(s2, max(s1, p)), b2p = min(s3, max(s2, p)), b3p = max(s3, p);
    const V b1q = min(s2, max(s1, q)), b2q = min(s3, max(s2, q)), b3q = max(s3, q);
    row(2, s0, s1, s2, s3, p, q);  // ranks 1, 2 and 3
    const V c1p = min(s1, max(s0, p)), c2p = min(s2, max(s1, p)), c3p = min(s3, max(s2, p));
    const V c1q = min(s1, max(s0, q)), c2q = min(s2, max(s1, q)), c3q = min(s3, max(s2, q));
    row(3, s0, s1, s2, s3, p, q);  // ranks 0, 1 and 2
    const V d1p = min(s0, p), d2p = min(s1, max(s0, p)), d3p = min(s2, max(s1, p));
    const V d1q = min(s0, q), d2q = min(s1, max(s0, q)), d3q = min(s2, max(s1, q));
    row(4, s0, s1, s2, s3, p, q);  // ranks 0 and 1
    const V e1p = min(s0, p), e2p = min(s1, max(s0, p));
    const V e1q = min(s0, q), e2q = min(s1, max(s0, q));
    const V at_even = median_of(a1p, a2p, b1p, b2p, b3p, c1p, c2p, c3p, d1p, d2p, d3p, e1p, e2p);
    const V at_odd = median_of(a1q, a2q, b1q, b2q, b3q, c1q, c2q, c3q, d1q, d2q, d3q, e1q, e2q);
    hn::StoreInterleaved2(at_even, at_odd, d, out + 2 * i0);
  });
  if (width > 2 * pairs) detail::median5_range(rows, width, width - 1, width, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(Median5Row);
HWY_EXPORT(Gaussian5VerticalRow);
HWY_EXPORT(RowFilter);
HWY_EXPORT(BoxVerticalRow);
HWY_EXPORT(SobelRow);

void median5_row(const float* const rows[5], int width, float* columns, float* out) {
  HWY_DYNAMIC_DISPATCH(Median5Row)(rows, width, columns, out);
}

void gaussian5_vertical_row(const std::uint8_t* const rows[5], const float* taps, int width,
                            float* out) {
  HWY_DYNAMIC_DISPATCH(Gaussian5VerticalRow)(rows, taps, width, out);
}

void row_filter(const float* in, int width, const float* taps, int radius, float* out) {
  HWY_DYNAMIC_DISPATCH(RowFilter)(in, width, taps, radius, out);
}

void box_vertical_row(const float* in, std::ptrdiff_t stride, int height, int y, int size,
                      float inv, int width, float* out) {
  HWY_DYNAMIC_DISPATCH(BoxVerticalRow)(in, stride, height, y, size, inv, width, out);
}

void sobel_row(const SobelRows& rows, float inv_norm, float* magnitude, std::uint8_t* direction) {
  HWY_DYNAMIC_DISPATCH(SobelRow)(rows, inv_norm, magnitude, direction);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
