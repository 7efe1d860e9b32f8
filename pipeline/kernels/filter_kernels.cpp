// SIMD versions of the contour stage's image filters, compiled once per Highway target and
// dispatched at run time. The interior columns go by whole vectors; the clamped borders and the
// last partial vector go to the scalar range functions, so the results equal
// dco::kernels::scalar bit for bit (the file is built without floating-point contraction).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/filter_kernels.hpp"
#include "filter_ranges.hpp"

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
  int x = begin;
  for (; x + n <= end; x += n) {
    const float* src = in + x - radius;
    auto sum = hn::Zero(d);
    for (int k = 0; k <= 2 * radius; ++k)
      sum = hn::Add(sum, hn::Mul(hn::Set(d, taps[k]), hn::LoadU(d, src + k)));
    hn::StoreU(sum, d, out + x);
  }
  detail::row_filter_range(in, width, taps, radius, x, width, out);
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
  int x = 1;
  for (; x + n <= end; x += n) {
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
  }
  detail::sobel_range(r, inv_norm, std::min(x, w), w, magnitude, direction);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(Gaussian5VerticalRow);
HWY_EXPORT(RowFilter);
HWY_EXPORT(BoxVerticalRow);
HWY_EXPORT(SobelRow);

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
