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

// The 25 values of a window as a 5x5 matrix, each column sorted, then each row: the matrix is
// then sorted along both, so element (i, j) has at least (i + 1)(j + 1) - 1 others at or below
// it and (5 - i)(5 - j) - 1 at or above it. Six elements are then below the median for sure and
// six above; the median is the 7th smallest of the other 13: the top two of row 0, the top
// three of row 1, the middle three of row 2, the bottom three of row 3 and the bottom two of
// row 4. Sorted runs of those merge with the rule that the k-th smallest of two sorted runs x
// and y is the least over i + j = k of max(x_i, y_j) (x_0 = y_0 = -inf). The columns are sorted
// once per row into `columns`; the compiler drops the row sorts' unused outputs.
void Median5Row(const float* const rows[5], int width, float* columns, float* out) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const int n = static_cast<int>(hn::Lanes(d));
  if (width < n) {
    detail::median5_range(rows, width, 0, width, out);
    return;
  }
  float* sorted[5];
  for (int k = 0; k < 5; ++k) sorted[k] = columns + k * (width + 4) + 2;
  int x = 0;
  for (; x + n <= width; x += n) {
    V a = hn::LoadU(d, rows[0] + x), b = hn::LoadU(d, rows[1] + x), c = hn::LoadU(d, rows[2] + x),
      e = hn::LoadU(d, rows[3] + x), f = hn::LoadU(d, rows[4] + x);
    Sort5(a, b, c, e, f);
    hn::StoreU(a, d, sorted[0] + x), hn::StoreU(b, d, sorted[1] + x);
    hn::StoreU(c, d, sorted[2] + x), hn::StoreU(e, d, sorted[3] + x);
    hn::StoreU(f, d, sorted[4] + x);
  }
  for (; x < width; ++x) {
    float v[5] = {rows[0][x], rows[1][x], rows[2][x], rows[3][x], rows[4][x]};
    std::sort(v, v + 5);
    for (int k = 0; k < 5; ++k) sorted[k][x] = v[k];
  }
  for (int k = 0; k < 5; ++k) {
    sorted[k][-2] = sorted[k][-1] = sorted[k][0];
    sorted[k][width] = sorted[k][width + 1] = sorted[k][width - 1];
  }
  const auto max = [](V p, V q) { return hn::Max(p, q); };
  const auto min = [](V p, V q) { return hn::Min(p, q); };
  // The last vector overlaps the one before it when width is not a multiple of n.
  for (x = 0; x < width; x += n) {
    const int at = std::min(x, width - n);
    // Sizeless (SVE) vectors make no arrays: one named vector per element.
    const auto sorted_row = [&](int i, V& v0, V& v1, V& v2, V& v3, V& v4) {
      const float* p = sorted[i] + at - 2;
      v0 = hn::LoadU(d, p), v1 = hn::LoadU(d, p + 1), v2 = hn::LoadU(d, p + 2);
      v3 = hn::LoadU(d, p + 3), v4 = hn::LoadU(d, p + 4);
      Sort5(v0, v1, v2, v3, v4);
    };
    V r00, r01, r02, r03, r04, r10, r11, r12, r13, r14, r20, r21, r22, r23, r24;
    V r30, r31, r32, r33, r34, r40, r41, r42, r43, r44;
    sorted_row(0, r00, r01, r02, r03, r04);
    sorted_row(1, r10, r11, r12, r13, r14);
    sorted_row(2, r20, r21, r22, r23, r24);
    sorted_row(3, r30, r31, r32, r33, r34);
    sorted_row(4, r40, r41, r42, r43, r44);
    // Rows 0 and 4 (two candidates each) into u, four sorted; row 3 joins it: t, seven.
    const V a1 = r03, a2 = r04, e1 = r40, e2 = r41;
    const V u1 = min(a1, e1), u2 = min(max(a1, e1), min(a2, e2));
    const V u3 = min(max(a2, e1), max(a1, e2)), u4 = max(a2, e2);
    const V d1 = r30, d2 = r31, d3 = r32;
    const V t1 = min(u1, d1);
    const V t2 = min(min(u2, d2), max(u1, d1));
    const V t3 = min(min(u3, d3), min(max(u2, d1), max(u1, d2)));
    const V t4 = min(min(u4, max(u3, d1)), min(max(u2, d2), max(u1, d3)));
    const V t5 = min(max(u4, d1), min(max(u3, d2), max(u2, d3)));
    const V t6 = min(max(u4, d2), max(u3, d3));
    const V t7 = max(u4, d3);
    // Rows 1 and 2 (three each) into s, six sorted.
    const V b1 = r12, b2 = r13, b3 = r14;
    const V c1 = r21, c2 = r22, c3 = r23;
    const V s1 = min(b1, c1);
    const V s2 = min(max(b1, c1), min(b2, c2));
    const V s3 = min(min(b3, c3), min(max(b2, c1), max(b1, c2)));
    const V s4 = min(max(b3, c1), min(max(b2, c2), max(b1, c3)));
    const V s5 = min(max(b3, c2), max(b2, c3));
    const V s6 = max(b3, c3);
    // The 7th smallest of s and t.
    V median = min(t7, max(s1, t6));
    median = min(median, min(max(s2, t5), max(s3, t4)));
    median = min(median, min(max(s4, t3), min(max(s5, t2), max(s6, t1))));
    hn::StoreU(median, d, out + at);
  }
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
