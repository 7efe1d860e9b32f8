// SIMD versions of the flow cue's row kernels, compiled once per Highway target and dispatched at
// run time: in the projection test the two bilinear samples per pixel are gathers, the rest (and
// the flow targets) whole-vector arithmetic in the reference's order; tails go to the scalar
// range.

#include <cstddef>
#include <cstdint>

#include "dco/kernels/flow_kernels.hpp"
#include "flow_ranges.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "flow_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// std::clamp(v, lo, hi), operation for operation.
template <class V>
HWY_INLINE V ClampAsStd(V v, V lo, V hi) {
  return hn::IfThenElse(hn::Lt(v, lo), lo, hn::IfThenElse(hn::Lt(hi, v), hi, v));
}

void ProjectionContrastRow(const FlowField& f, int y, float distance, float min_length,
                           float* contrast) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const int n = static_cast<int>(hn::Lanes(d));
  const float* row = f.data + y * f.stride;
  const auto zero = hn::Zero(d);
  const auto one = hn::Set(d, 1.0f);
  const auto max_x = hn::Set(d, static_cast<float>(f.width - 1));
  const auto max_y = hn::Set(d, static_cast<float>(f.height - 1));
  const auto last_x = hn::Set(di, f.width - 1);
  const auto last_y = hn::Set(di, f.height - 1);
  const auto stride = hn::Set(di, static_cast<int>(f.stride));
  const auto dist = hn::Set(d, distance);
  const auto min_len = hn::Set(d, min_length);
  const auto yf = hn::Set(d, static_cast<float>(y));
  const auto lanes = hn::ConvertTo(d, hn::Iota(di, 0));
  // The flow vectors (u, v) at float indices i (of u). Where the target gathers in hardware and
  // every vector is one aligned 64-bit word (an even row stride), one gather of words takes half
  // as many elements as gathering u and v apart; elsewhere gathers are scalar loads anyway.
#if HWY_TARGET == HWY_AVX2 || HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  const bool pairs =
      f.stride % 2 == 0 && reinterpret_cast<std::uintptr_t>(f.data) % sizeof(std::uint64_t) == 0;
#else
  constexpr bool pairs = false;
#endif
  const hn::Half<decltype(di)> dih;
  const hn::Repartition<std::int64_t, decltype(d)> di64;
  const hn::Repartition<std::uint64_t, decltype(d)> du64;
  const auto* words = reinterpret_cast<const std::uint64_t*>(f.data);
  const auto pair_at = [&](hn::Vec<decltype(di)> i, hn::Vec<decltype(d)>& u,
                           hn::Vec<decltype(d)>& v) {
    if (!pairs) {
      u = hn::GatherIndex(d, f.data, i);
      v = hn::GatherIndex(d, f.data, hn::Add(i, hn::Set(di, 1)));
      return;
    }
    const auto word = hn::ShiftRight<1>(i);
    const auto lo =
        hn::BitCast(d, hn::GatherIndex(du64, words, hn::PromoteTo(di64, hn::LowerHalf(dih, word))));
    const auto hi =
        hn::BitCast(d, hn::GatherIndex(du64, words, hn::PromoteTo(di64, hn::UpperHalf(dih, word))));
    u = hn::ConcatEven(d, hi, lo);
    v = hn::ConcatOdd(d, hi, lo);
  };
  // Bilinear sample of both channels at (px, py), already clamped.
  const auto sample = [&](hn::Vec<decltype(d)> px, hn::Vec<decltype(d)> py, hn::Vec<decltype(d)>& u,
                          hn::Vec<decltype(d)>& v) {
    const auto x0 = hn::ConvertTo(di, px);
    const auto y0 = hn::ConvertTo(di, py);
    const auto x1 = hn::Min(hn::Add(x0, hn::Set(di, 1)), last_x);
    const auto y1 = hn::Min(hn::Add(y0, hn::Set(di, 1)), last_y);
    const auto fx = hn::Sub(px, hn::ConvertTo(d, x0));
    const auto fy = hn::Sub(py, hn::ConvertTo(d, y0));
    const auto gx = hn::Sub(one, fx), gy = hn::Sub(one, fy);
    const auto w00 = hn::Mul(gx, gy), w10 = hn::Mul(fx, gy), w01 = hn::Mul(gx, fy),
               w11 = hn::Mul(fx, fy);
    const auto r0 = hn::Mul(y0, stride), r1 = hn::Mul(y1, stride);
    const auto c0 = hn::Add(x0, x0), c1 = hn::Add(x1, x1);
    const auto i00 = hn::Add(r0, c0), i10 = hn::Add(r0, c1), i01 = hn::Add(r1, c0),
               i11 = hn::Add(r1, c1);
    hn::Vec<decltype(d)> u00, v00, u10, v10, u01, v01, u11, v11;
    pair_at(i00, u00, v00);
    pair_at(i10, u10, v10);
    pair_at(i01, u01, v01);
    pair_at(i11, u11, v11);
    u = hn::Add(hn::Add(hn::Add(hn::Mul(w00, u00), hn::Mul(w10, u10)), hn::Mul(w01, u01)),
                hn::Mul(w11, u11));
    v = hn::Add(hn::Add(hn::Add(hn::Mul(w00, v00), hn::Mul(w10, v10)), hn::Mul(w01, v01)),
                hn::Mul(w11, v11));
  };
  int x = 0;
  for (; x + n <= f.width; x += n) {
    hn::Vec<decltype(d)> u, v;
    hn::LoadInterleaved2(d, row + 2 * x, u, v);
    const auto len = hn::Sqrt(hn::Add(hn::Mul(u, u), hn::Mul(v, v)));
    const auto moving = hn::Not(hn::Lt(len, min_len));
    if (hn::AllFalse(d, moving)) {
      hn::StoreU(zero, d, contrast + x);
      continue;
    }
    // Lanes too slow to have a direction divide by a safe 1 and are zeroed at the end.
    const auto safe_len = hn::IfThenElse(moving, len, one);
    const auto ex = hn::Div(u, safe_len);
    const auto ey = hn::Div(v, safe_len);
    const auto dx = hn::Mul(dist, ex);
    const auto dy = hn::Mul(dist, ey);
    const auto xf = hn::Add(hn::Set(d, static_cast<float>(x)), lanes);
    hn::Vec<decltype(d)> u0, v0, u1, v1;
    sample(ClampAsStd(hn::Sub(xf, dx), zero, max_x), ClampAsStd(hn::Sub(yf, dy), zero, max_y), u0,
           v0);
    sample(ClampAsStd(hn::Add(xf, dx), zero, max_x), ClampAsStd(hn::Add(yf, dy), zero, max_y), u1,
           v1);
    const auto c = hn::Sub(hn::Add(hn::Mul(u1, ex), hn::Mul(v1, ey)),
                           hn::Add(hn::Mul(u0, ex), hn::Mul(v0, ey)));
    hn::StoreU(hn::IfThenElseZero(moving, c), d, contrast + x);
  }
  detail::projection_contrast_range(f, y, distance, min_length, x, f.width, contrast);
}

void FlowTargetsRow(const FlowField& f, int y, std::int32_t* column, std::int32_t* row,
                    float* speed) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const int n = static_cast<int>(hn::Lanes(d));
  const float* r = f.data + y * f.stride;
  const auto zero = hn::Zero(d);
  const auto half = hn::Set(d, 0.5f);
  const auto w = hn::Set(d, static_cast<float>(f.width));
  const auto h = hn::Set(d, static_cast<float>(f.height));
  const auto yf = hn::Set(d, static_cast<float>(y));
  const auto lanes = hn::ConvertTo(d, hn::Iota(di, 0));
  const auto none = hn::Set(di, -1);
  int x = 0;
  for (; x + n <= f.width; x += n) {
    hn::Vec<decltype(d)> u, v;
    hn::LoadInterleaved2(d, r + 2 * x, u, v);
    const auto tx = hn::Add(hn::Add(hn::Add(hn::Set(d, static_cast<float>(x)), lanes), u), half);
    const auto ty = hn::Add(hn::Add(yf, v), half);
    // Comparisons with NaN are false, so NaN lands nowhere, as in the reference.
    const auto inside =
        hn::And(hn::And(hn::Ge(tx, zero), hn::Lt(tx, w)), hn::And(hn::Ge(ty, zero), hn::Lt(ty, h)));
    const auto inside_i = hn::RebindMask(di, inside);
    // Lanes outside are replaced before the conversion, which keeps it in range.
    hn::StoreU(hn::IfThenElse(inside_i, hn::ConvertTo(di, hn::IfThenElseZero(inside, tx)), none),
               di, column + x);
    hn::StoreU(hn::ConvertTo(di, hn::IfThenElseZero(inside, ty)), di, row + x);
    hn::StoreU(hn::Add(hn::Mul(u, u), hn::Mul(v, v)), d, speed + x);
  }
  detail::flow_targets_range(f, y, x, f.width, column, row, speed);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(ProjectionContrastRow);
HWY_EXPORT(FlowTargetsRow);

void projection_contrast_row(const FlowField& flow, int y, float distance, float min_length,
                             float* contrast) {
  HWY_DYNAMIC_DISPATCH(ProjectionContrastRow)(flow, y, distance, min_length, contrast);
}

void flow_targets_row(const FlowField& flow, int y, std::int32_t* column, std::int32_t* row,
                      float* speed) {
  HWY_DYNAMIC_DISPATCH(FlowTargetsRow)(flow, y, column, row, speed);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
